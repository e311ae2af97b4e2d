"""`fk`, `ik` and `simulate`: the robot's kinematics and the tool-tip control diagram."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from drake_tooluse.cli.common import (
    EXIT_NOT_REACHED,
    EXIT_OK,
    UsageError,
    add_meshcat_arg,
    add_scenario_args,
    add_tool_args,
    measured_belief,
    open_meshcat,
    output_file_arg,
    pose_dict,
    scenario_from_args,
    tool_length_arg,
    tool_length_from_args,
)
from drake_tooluse.paths import DEFAULT_SCENARIO

# Tool-tip targets are looked for this far from Baxter's base at most (it reaches ~1.3 m).
MAX_TARGET_DISTANCE = 10.0  # m, per coordinate


def cmd_fk(args) -> dict:
    from drake_tooluse.robot.ik import ToolTipIK

    length = tool_length_from_args(args)
    ik = ToolTipIK(length, library_size=1)
    q = ik.check_q(args.q, "--q")
    return {
        "tool_length_m": length,
        "q": q.tolist(),
        "tip": pose_dict(ik.fk(q)),
        "gripper": pose_dict(ik.fk_gripper(q)),
    }


def format_fk(out: dict) -> str:
    t = out["tip"]
    return (
        f"tool tip in world: position {np.round(t['position_m'], 5).tolist()} m, "
        f"quaternion wxyz {np.round(t['quaternion_wxyz'], 5).tolist()}, "
        f"rpy {np.round(t['rpy_rad'], 5).tolist()} rad"
    )


def _target_pose(args):
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform, RollPitchYaw

    from drake_tooluse.robot.model import TOOL_DOWN_RPY
    from drake_tooluse.validation import check_finite_vector, check_unit_quaternion

    p = check_finite_vector(args.position, 3, "--position")
    if np.any(np.abs(p) > MAX_TARGET_DISTANCE):
        raise UsageError(
            f"--position={p.tolist()} m is outside the allowed range [-{MAX_TARGET_DISTANCE:g}, "
            f"{MAX_TARGET_DISTANCE:g}] m per coordinate (Baxter reaches about 1.3 m)"
        )
    if args.quaternion is not None:
        if args.rpy is not None:
            raise UsageError("give either --rpy or --quaternion, not both")
        return RigidTransform(Quaternion(check_unit_quaternion(args.quaternion, "--quaternion")), p)
    rpy = check_finite_vector(args.rpy if args.rpy is not None else TOOL_DOWN_RPY, 3, "--rpy")
    return RigidTransform(RollPitchYaw(rpy), p)


def cmd_ik(args) -> dict:
    from drake_tooluse.robot.ik import ToolTipIK
    from drake_tooluse.robot.model import RobotBelief

    measured = {}
    if args.scenario is not None and not args.measure:
        raise UsageError("--scenario is the world --measure measures: give --measure with it")
    if args.measure:
        if args.scenario is None:
            args.scenario = DEFAULT_SCENARIO
        belief, measured = measured_belief(scenario_from_args(args))
    else:
        belief = RobotBelief(tool_length_from_args(args))
    X = _target_pose(args)
    ik = ToolTipIK(belief.tool, grasp_offset=belief.grasp_offset)
    seed = None if args.seed_q is None else ik.check_q(args.seed_q, "--seed-q")
    result = ik.solve(X, seed)
    out = {"tool_length_m": belief.tool_length, **measured, "target": pose_dict(X)}
    out.update(result.as_dict())
    return out


def format_ik(out: dict) -> str:
    head = (
        "reached"
        if out["success"]
        else f"NOT REACHED (exit code {EXIT_NOT_REACHED}): found no joint angles that put the "
        "tip at the pose within tolerance; the closest found"
    )
    return (
        f"{head}: q {np.round(out['q'], 5).tolist()} rad\n"
        f"tip error {out['position_error_m'] * 1e3:.4g} mm, "
        f"{out['orientation_error_rad']:.3g} rad; solve {out['solve_time_s'] * 1e3:.2f} ms"
        f" ({out['attempts']} attempt(s))"
    )


def ik_status(out: dict) -> int:
    """The exit code of `ik`: EXIT_NOT_REACHED when it found no solution."""
    return EXIT_OK if out["success"] else EXIT_NOT_REACHED


def _parse_waypoint(text: str):
    from pydrake.math import RigidTransform, RollPitchYaw

    from drake_tooluse.robot.model import TOOL_DOWN_RPY

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise UsageError(
            f"waypoint {text!r} is not 'x,y,z' or 'x,y,z,roll,pitch,yaw' (m, rad)"
        ) from None
    if len(values) not in (3, 6) or not np.all(np.isfinite(values)):
        raise UsageError(
            f"waypoint {text!r} needs 3 (x,y,z m) or 6 (x,y,z m, roll,pitch,yaw rad) finite numbers"
        )
    if any(abs(v) > MAX_TARGET_DISTANCE for v in values[:3]):
        raise UsageError(
            f"waypoint {text!r}: positions must be in [-{MAX_TARGET_DISTANCE:g}, "
            f"{MAX_TARGET_DISTANCE:g}] m"
        )
    rpy = values[3:] if len(values) == 6 else TOOL_DOWN_RPY
    return RigidTransform(RollPitchYaw(rpy), values[:3])


def cmd_simulate(args) -> dict:
    from drake_tooluse.builders.trajectory_diagram import simulate_waypoints
    from drake_tooluse.robot.model import RobotBelief

    if args.record is not None:  # before the simulation, not after it
        output_file_arg(args.record, "--record")
    scenario = scenario_from_args(args)
    waypoints = [_parse_waypoint(w) for w in args.tip_waypoints]
    meshcat = open_meshcat(args)
    start = time.perf_counter()
    measured, belief = {}, None
    if args.measure:
        if args.believed_tool_length is not None:
            raise UsageError("give either --measure or --believed-tool-length, not both")
        belief, measured = measured_belief(scenario)
    elif args.believed_tool_length is not None:
        belief = RobotBelief(tool_length_arg(args.believed_tool_length, "--believed-tool-length"))
    run = simulate_waypoints(
        scenario,
        waypoints,
        move_time=args.move_time,
        dwell=args.dwell,
        belief=belief,
        record=args.record,
        meshcat=meshcat,
    )
    errors = [r.position_error for r in run.results]
    believed = belief.tool_length if belief is not None else scenario.tool.length
    return {
        "scenario": str(args.scenario),
        "tool_length_m": scenario.tool.length,
        "believed_tool_length_m": believed,
        **measured,
        "waypoints": [r.as_dict() for r in run.results],
        "max_position_error_m": max(errors),
        "mean_position_error_m": float(np.mean(errors)),
        "sim_time_s": run.sim_time,
        "wall_time_s": time.perf_counter() - start,
        "recording": str(run.recording) if run.recording else None,
        **({"meshcat_url": meshcat.web_url()} if meshcat is not None else {}),
    }


def format_simulate(out: dict) -> str:
    lines = [
        f"waypoint {i}: target {np.round(w['target_m'], 4).tolist()} m, "
        f"tip error {w['position_error_m'] * 1e3:.3g} mm, "
        f"{w['orientation_error_rad']:.2e} rad, IK ok {w['ik_success']}"
        for i, w in enumerate(out["waypoints"])
    ]
    lines.append(
        f"max tip error {out['max_position_error_m'] * 1e3:.3g} mm; "
        f"{out['sim_time_s']:.1f} s simulated in {out['wall_time_s']:.1f} s"
    )
    failed = [i for i, w in enumerate(out["waypoints"]) if not w["ik_success"]]
    if failed:
        lines.append(
            f"NOT REACHED (exit code {EXIT_NOT_REACHED}): the IK found no joint angles for "
            f"waypoint(s) {failed}; the arm held its last solved joint angles"
        )
    if out["recording"]:
        lines.append(f"recording: {out['recording']}")
    return "\n".join(lines)


def simulate_status(out: dict) -> int:
    """The exit code of `simulate`: EXIT_NOT_REACHED when the IK failed at any waypoint."""
    return EXIT_OK if all(w["ik_success"] for w in out["waypoints"]) else EXIT_NOT_REACHED


def add_parsers(sub) -> None:
    p = sub.add_parser("fk", help="tool-tip pose in the world at given right-arm joint angles")
    add_tool_args(p)
    p.add_argument(
        "--q",
        type=float,
        nargs="+",
        required=True,
        metavar="RAD",
        help="7 right-arm joint angles s0 s1 e0 e1 w0 w1 w2 (rad)",
    )
    p.set_defaults(run=cmd_fk, show=format_fk)

    p = sub.add_parser(
        "ik",
        help="joint angles that put the tool tip at a pose (exit code "
        f"{EXIT_NOT_REACHED} if none does)",
    )
    add_tool_args(p)
    p.add_argument(
        "--position",
        type=float,
        nargs="+",
        required=True,
        metavar="M",
        help="tip position x y z in the world (Baxter base) frame, m",
    )
    p.add_argument(
        "--rpy",
        type=float,
        nargs="+",
        metavar="RAD",
        help="tip orientation roll pitch yaw, rad (default: tool pointing down)",
    )
    p.add_argument(
        "--quaternion",
        type=float,
        nargs="+",
        metavar="Q",
        help="tip orientation as a quaternion w x y z (instead of --rpy)",
    )
    p.add_argument(
        "--seed-q", type=float, nargs="+", metavar="RAD", help="warm start: 7 joint angles (rad)"
    )
    p.add_argument(
        "--measure",
        action="store_true",
        help="measure the tool with the head camera first (the world's tool: "
        "--scenario, with --tool-length as its true length) and solve for the "
        "measured tool (length and grasp along it)",
    )
    p.add_argument(
        "--scenario",
        type=Path,
        help=f"scenario YAML, with --measure (default: {DEFAULT_SCENARIO})",
    )
    p.set_defaults(run=cmd_ik, show=format_ik, status=ik_status)

    p = sub.add_parser(
        "simulate",
        help="move the tool tip through waypoints in the dynamic "
        f"simulation with the IK in the loop (exit code {EXIT_NOT_REACHED} if the IK finds no "
        "joint angles for a waypoint)",
    )
    add_scenario_args(p)
    p.add_argument(
        "--believed-tool-length",
        type=float,
        metavar="L",
        help="tool length the robot model believes (m); default the true one",
    )
    p.add_argument(
        "--tip-waypoints",
        nargs="+",
        required=True,
        metavar="X,Y,Z[,R,P,Y]",
        help="tip waypoints in m (and rad); the tool points down if no rpy",
    )
    p.add_argument("--move-time", type=float, default=1.0, help="s per move")
    p.add_argument("--dwell", type=float, default=1.5, help="s held at each waypoint")
    p.add_argument(
        "--record", type=Path, metavar="HTML", help="write a Meshcat recording (standalone HTML)"
    )
    p.add_argument(
        "--measure",
        action="store_true",
        help="measure the tool with the head camera first; the robot model then "
        "holds the measured length and grasp along the tool",
    )
    add_meshcat_arg(p, "the run (then its recording, to play again)")
    p.set_defaults(run=cmd_simulate, show=format_simulate, status=simulate_status)
