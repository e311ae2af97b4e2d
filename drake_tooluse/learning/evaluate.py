"""Evaluating a policy, and the one episode loop every policy rollout runs."""

from __future__ import annotations

from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np

from drake_tooluse.learning.policy_dir import (
    LoadedPolicy,
    check_policy_env,
    check_policy_matches,
    load_policy,
)
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.progress import progress_bar
from drake_tooluse.validation import check_int, check_seed


@dataclass
class EvalResult:
    """An evaluation's figures: the generic ones, and `metrics`, the summaries of the figures
    the env's task declares (`TaskEnv.EPISODE_METRICS`: for the push task the final box–goal
    distance, the box travel, which bodies touched the box)."""

    episodes: int
    seed: int
    success_rate: float
    episode_length_mean: float
    metrics: dict
    # Episodes the simulation failed in (truncated with finite values; counted as failures).
    sim_errors: int = 0
    # Per flag of the task's `PHYSICAL_LIMITS`: the episodes in which any step was past it.
    flagged_episodes: dict = field(default_factory=dict)
    # Each episode ran to its step limit (or its simulation failure) and was judged where it
    # ended: no episode terminated, or `to_time_limit` ran each on past it (`run_episode`).
    to_time_limit: bool = False
    per_episode: list = field(default_factory=list)

    def as_dict(self) -> dict:
        """The figures as one flat mapping (the task's metrics beside the generic ones), as
        `evaluate --json` prints them and policies' metrics.json hold them."""
        d = {"episodes": self.episodes, "seed": self.seed, **self.metrics}
        d.update(
            success_rate=self.success_rate,
            episode_length_mean=self.episode_length_mean,
            sim_errors=self.sim_errors,
            flagged_episodes=dict(self.flagged_episodes),
            to_time_limit=self.to_time_limit,
            per_episode=self.per_episode,
        )
        return d


class PhysicalSanity:
    """One episode's physical sanity, step by step (`run_episode`'s `on_step`): for each of the
    task's `PHYSICAL_LIMITS`, whether any step was past it and the figure's largest value."""

    def __init__(self, limits):
        self._limits = limits
        self._flagged = {lim.flag: False for lim in limits}
        self._peak = {lim.info_key: 0.0 for lim in limits}

    def add(self, step: int, info: dict) -> None:
        for lim in self._limits:
            self._flagged[lim.flag] |= bool(info[lim.flag])
            self._peak[lim.info_key] = max(self._peak[lim.info_key], float(info[lim.info_key]))

    def row(self) -> dict:
        """The episode's flags (`flag`: any step past the limit) and peaks (`peak_<info_key>`)."""
        return {**self._flagged, **{f"peak_{k}": v for k, v in self._peak.items()}}


def make_policy_env(
    policy_dir,
    env_id: str | None = None,
    env_kwargs: dict | None = None,
    trust_pickle: bool = False,
):
    """Loads a policy directory (or takes a policy already loaded from one) and makes the env
    it acts in: its own env id and kwargs unless `env_id` / `env_kwargs` override them
    (`check_policy_env`: the id registered, the kwargs valid, the spaces the policy's).
    Returns (policy, env)."""
    if isinstance(policy_dir, LoadedPolicy):
        policy = policy_dir
    else:
        policy = load_policy(policy_dir, trust_pickle=trust_pickle)
    env_id, kwargs = check_policy_env(policy, env_id, env_kwargs)
    env = gym.make(env_id, **kwargs)
    check_policy_matches(policy, env)
    return policy, env


def run_episode(env, policy, seed: int, on_step=None, to_time_limit: bool = False):
    """One deterministic episode of `policy` from `env.reset(seed=seed)` until it terminates
    or is truncated (the step limit, or a simulation failure) — with `to_time_limit`, on past a
    termination until it is truncated, for an env that terminates (the project's envs do not:
    their episodes run to the step limit). `on_step(step, info)` is called after the reset
    (step 0) and after each step. Returns the last info and the number of steps."""
    obs, info = env.reset(seed=seed)
    if on_step is not None:
        on_step(0, info)
    # The step limit counted here too: a TimeLimit patched not to truncate a terminated step
    # (rl_zoo3's, once imported) would otherwise let a held success run on forever.
    limit = env.spec.max_episode_steps if env.spec is not None else None
    steps = 0
    while True:
        obs, _, terminated, truncated, info = env.step(policy.act(obs))
        steps += 1
        if on_step is not None:
            on_step(steps, info)
        if truncated or (terminated and not to_time_limit) or steps == limit:
            return info, steps


def evaluate(
    policy_dir,
    env_id: str | None = None,
    episodes: int = 100,
    seed: int = 0,
    env_kwargs: dict | None = None,
    trust_pickle: bool = False,
    progress: bool = False,
    to_time_limit: bool = False,
) -> EvalResult:
    """Runs the policy deterministically for `episodes` episodes, seeds seed, seed+1, …; an
    episode the simulation failed in counts as a failure and in `sim_errors`. With
    `to_time_limit` each episode runs on past a termination to the step limit and is judged
    where it ends (`run_episode`). With `progress`, a bar of the episodes (and the success so
    far) on stderr, when stderr is a terminal."""
    check_int(episodes, 1, MAX_EPISODES, "episodes")
    check_seed(seed, "seed", episodes)
    policy, env = make_policy_env(policy_dir, env_id, env_kwargs, trust_pickle)
    task_env = type(env.unwrapped)
    task_metrics = task_env.EPISODE_METRICS
    limits = task_env.PHYSICAL_LIMITS
    limit = env.spec.max_episode_steps if env.spec is not None else None
    rows = []
    bar = progress_bar(episodes, "episodes", "ep", progress)
    try:
        for ep in range(episodes):
            sanity = PhysicalSanity(limits)
            info, steps = run_episode(
                env, policy, seed + ep, on_step=sanity.add, to_time_limit=to_time_limit
            )
            rows.append(
                {
                    "seed": seed + ep,
                    **{m.name: m.read(info) for m in task_metrics},
                    "success": bool(info["is_success"]) and not info["sim_error"],
                    "length": steps,
                    "sim_error": bool(info["sim_error"]),
                    **sanity.row(),
                }
            )
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in rows]) * 100:.0f}%")
    finally:
        bar.close()
        env.close()
    metrics = {}
    for m in task_metrics:
        metrics.update(m.summary([r[m.name] for r in rows]))
    return EvalResult(
        episodes=episodes,
        seed=seed,
        success_rate=float(np.mean([r["success"] for r in rows])),
        episode_length_mean=float(np.mean([r["length"] for r in rows])),
        metrics=metrics,
        sim_errors=sum(r["sim_error"] for r in rows),
        flagged_episodes={lim.flag: sum(r[lim.flag] for r in rows) for lim in limits},
        to_time_limit=to_time_limit or all(r["length"] == limit or r["sim_error"] for r in rows),
        per_episode=rows,
    )
