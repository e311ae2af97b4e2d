"""What the commands share: usage errors, the tool and scenario options, pose printing."""

from __future__ import annotations

import argparse
from pathlib import Path

from drake_tooluse.paths import DEFAULT_SCENARIO


class UsageError(ValueError):
    """Bad input at the command line."""


def add_tool_args(p: argparse.ArgumentParser) -> None:
    """--tool-length L or --no-tool: the tool the robot model holds."""
    p.add_argument("--tool-length", type=float, metavar="L", help="tool length in m, in (0, 0.60]")
    p.add_argument("--no-tool", action="store_true", help="the tip frame is the gripper frame")


def tool_length_from_args(args) -> float | None:
    from drake_tooluse.robot.model import check_tool_length

    if args.no_tool:
        if args.tool_length is not None:
            raise UsageError("give either --tool-length or --no-tool, not both")
        return None
    if args.tool_length is None:
        raise UsageError("give --tool-length L (m, in (0, 0.60]) or --no-tool")
    return check_tool_length(args.tool_length, "--tool-length")


def add_scenario_args(p: argparse.ArgumentParser) -> None:
    """--scenario FILE and --tool-length L (the world's true tool)."""
    p.add_argument(
        "--scenario",
        type=Path,
        default=DEFAULT_SCENARIO,
        help="scenario YAML (default: %(default)s)",
    )
    p.add_argument(
        "--tool-length",
        type=float,
        metavar="L",
        help="override the scenario's true tool length (m, in (0, 0.60])",
    )


def scenario_from_args(args):
    """The scenario of `add_scenario_args`' options, validated."""
    from drake_tooluse.world.scenario import load_scenario, with_tool_length

    scenario = load_scenario(args.scenario)
    if args.tool_length is not None:
        scenario = with_tool_length(scenario, args.tool_length)
    return scenario


def measured_belief(scenario) -> tuple[object, dict]:
    """Measures the scenario's (true) tool with the head camera: the robot's belief (its
    length and where the hand holds it along it) and the figures to print."""
    from drake_tooluse.diagrams.measurement import measure_belief

    belief, result = measure_belief(scenario)
    return belief, {
        "measured_tool_length_m": result.length,
        "true_tool_length_m": scenario.tool.length,
        "measured_grasp_along_m": result.grasp_along,
        "true_grasp_along_m": scenario.tool.grasp_offset_along,
        "measurement_spread_m": result.spread,
        "measurement_time_s": result.wall_time,
    }


def pose_dict(X) -> dict:
    from pydrake.math import RollPitchYaw

    return {
        "position_m": X.translation().tolist(),
        "quaternion_wxyz": X.rotation().ToQuaternion().wxyz().tolist(),
        "rpy_rad": RollPitchYaw(X.rotation()).vector().tolist(),
    }


def parse_json_arg(text: str | None, name: str):
    """A JSON option's value (None if not given); bad JSON is a usage error naming the option."""
    import json

    if not text:
        return None
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise UsageError(f"{name} is not valid JSON ({e}): {text!r}") from None
