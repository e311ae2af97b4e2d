"""Any task's figures in words, with units, read from their names (the task contract's
`EpisodeMetric` names and summaries): what `evaluate`, `record-video` and the study print."""

from __future__ import annotations

# What evaluate's result holds beside the task's figures.
NOT_FIGURES = ("episodes", "seed", "to_time_limit", "per_episode", "meshcat_url")
NOT_FIGURES += ("flagged_episodes", "env_id", "object_name", "sim_errors")
UNITS = {"m": (100.0, "cm", ".2f"), "deg": (1.0, "°", ".1f"), "s": (1.0, "s", ".2f")}


def _figure_name(name: str, thing: str) -> str:
    return name.replace("object", thing).replace("_", " ")


def format_figures(out: dict, thing: str = "object") -> str:
    """Any task's evaluation figures in words, with units, from their names (the task
    contract's `EpisodeMetric` summaries): `<name>_<mean|median|std>_<unit>` together,
    `<name>_rate` and `success_rate` as a percentage, `episode_length_mean` in steps, one
    episode's `<name>_<unit>` with its unit; `object` in a name read as `thing`."""
    stats, parts = {}, []
    for key, value in out.items():
        if key in NOT_FIGURES or isinstance(value, bool) or not isinstance(value, (int, float)):
            continue
        name, _, unit = key.rpartition("_")
        base, _, stat = name.rpartition("_")
        if unit in UNITS and stat in ("mean", "median", "std"):
            if base not in stats:
                stats[base] = []
                parts.append((base, stats[base]))
            scale, symbol, spec = UNITS[unit]
            stats[base].append(f"{stat} {value * scale:{spec}} {symbol}".replace(" °", "°"))
        elif key == "success_rate":
            parts.append(f"success {value * 100:.0f} %")
        elif unit == "rate":
            parts.append(f"{_figure_name(name, thing)} in {value * 100:.0f} % of episodes")
        elif key == "episode_length_mean":
            parts.append(f"episode length {value:.1f} steps")
        elif unit in UNITS:  # one episode's figure
            scale, symbol, spec = UNITS[unit]
            parts.append(f"{_figure_name(name, thing)} {value * scale:{spec}} {symbol}")
        else:
            parts.append(f"{_figure_name(key, thing)} {value:.4g}")
    return "; ".join(
        f"{_figure_name(p[0], thing)}: {', '.join(p[1])}" if isinstance(p, tuple) else p
        for p in parts
    )
