"""`drake-tooluse`: the command line. Every command takes `--json` for scripts."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path

import numpy as np

REPO_DIR = Path(__file__).resolve().parent.parent
DIAGRAMS_DIR = REPO_DIR / "diagrams"
DEFAULT_SCENARIO = DIAGRAMS_DIR / "push.yaml"
SHIPPED_POLICY = REPO_DIR / "models" / "policies" / "ppo_toolpush"
# The policy for other tools: it observes the task in tool-tip space only (see task.py).
TRANSFER_POLICY = REPO_DIR / "models" / "policies" / "ppo_toolpush_tip"


class UsageError(ValueError):
    """Bad input at the command line."""


def _tool_length(args) -> float | None:
    from drake_tooluse.scenario import check_tool_length

    if args.no_tool:
        if args.tool_length is not None:
            raise UsageError("give either --tool-length or --no-tool, not both")
        return None
    if args.tool_length is None:
        raise UsageError("give --tool-length L (m, in (0, 0.60]) or --no-tool")
    return check_tool_length(args.tool_length, "--tool-length")


def _add_tool_args(p) -> None:
    p.add_argument("--tool-length", type=float, metavar="L",
                   help="tool length in m, in (0, 0.60]")
    p.add_argument("--no-tool", action="store_true", help="the tip frame is the gripper frame")


def _pose_dict(X) -> dict:
    from pydrake.math import RollPitchYaw

    return {"position_m": X.translation().tolist(),
            "quaternion_wxyz": X.rotation().ToQuaternion().wxyz().tolist(),
            "rpy_rad": RollPitchYaw(X.rotation()).vector().tolist()}


def cmd_fk(args) -> dict:
    from drake_tooluse.ik import ToolTipIK

    length = _tool_length(args)
    ik = ToolTipIK(length, library_size=1)
    q = ik.check_q(args.q, "--q")
    return {"tool_length_m": length, "q": q.tolist(), "tip": _pose_dict(ik.fk(q)),
            "gripper": _pose_dict(ik.fk_gripper(q))}


def _target_pose(args):
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform, RollPitchYaw

    from drake_tooluse.validation import check_finite_vector, check_unit_quaternion

    p = check_finite_vector(args.position, 3, "--position")
    if args.quaternion is not None:
        if args.rpy is not None:
            raise UsageError("give either --rpy or --quaternion, not both")
        return RigidTransform(Quaternion(check_unit_quaternion(args.quaternion, "--quaternion")),
                              p)
    rpy = check_finite_vector(args.rpy if args.rpy is not None else [np.pi, 0.0, np.pi / 2], 3,
                              "--rpy")
    return RigidTransform(RollPitchYaw(rpy), p)


def _measured_tool(scenario) -> dict:
    """Measures the scenario's (true) tool with the head camera: its length and where the hand
    holds it along it."""
    from drake_tooluse.measure import measure_tool

    result = measure_tool(scenario)
    return {"measured_tool_length_m": result.length, "true_tool_length_m": scenario.tool.length,
            "measured_grasp_along_m": result.grasp_along,
            "true_grasp_along_m": scenario.tool.grasp_offset_along,
            "measurement_spread_m": result.spread, "measurement_time_s": result.wall_time}


def cmd_ik(args) -> dict:
    from drake_tooluse.ik import ToolTipIK

    measured, grasp = {}, (0.0, 0.0)
    if args.measure:
        measured = _measured_tool(scenario_from_args(args))
        length = measured["measured_tool_length_m"]
        grasp = (0.0, measured["measured_grasp_along_m"])
    else:
        length = _tool_length(args)
    X = _target_pose(args)
    ik = ToolTipIK(length, grasp_offset=grasp)
    seed = None if args.seed_q is None else ik.check_q(args.seed_q, "--seed-q")
    result = ik.solve(X, seed)
    out = {"tool_length_m": length, **measured, "target": _pose_dict(X)}
    out.update(result.as_dict())
    return out


def _parse_waypoint(text: str):
    from pydrake.math import RigidTransform, RollPitchYaw

    from drake_tooluse.scene import TOOL_DOWN_RPY

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise UsageError(f"waypoint {text!r} is not 'x,y,z' or 'x,y,z,roll,pitch,yaw' "
                         "(m, rad)") from None
    if len(values) not in (3, 6) or not np.all(np.isfinite(values)):
        raise UsageError(f"waypoint {text!r} needs 3 (x,y,z m) or 6 (x,y,z m, roll,pitch,yaw "
                         "rad) finite numbers")
    rpy = values[3:] if len(values) == 6 else TOOL_DOWN_RPY
    return RigidTransform(RollPitchYaw(rpy), values[:3])


def add_scenario_args(p) -> None:
    """--scenario FILE and --tool-length L (the world's true tool), shared by commands."""
    p.add_argument("--scenario", type=Path, default=DEFAULT_SCENARIO, help="scenario YAML")
    p.add_argument("--tool-length", type=float, metavar="L",
                   help="override the scenario's true tool length (m, in (0, 0.60])")


def scenario_from_args(args):
    """The scenario of `add_scenario_args`' options, validated."""
    from drake_tooluse.scenario import load_scenario, with_tool_length

    scenario = load_scenario(args.scenario)
    if args.tool_length is not None:
        scenario = with_tool_length(scenario, args.tool_length)
    return scenario


def cmd_simulate(args) -> dict:
    from drake_tooluse.simulation import simulate_waypoints

    scenario = scenario_from_args(args)
    waypoints = [_parse_waypoint(w) for w in args.tip_waypoints]
    start = time.perf_counter()
    measured, grasp = {}, (0.0, 0.0)
    believed = args.believed_tool_length
    if args.measure:
        if believed is not None:
            raise UsageError("give either --measure or --believed-tool-length, not both")
        measured = _measured_tool(scenario)
        believed = measured["measured_tool_length_m"]
        grasp = (0.0, measured["measured_grasp_along_m"])
    run = simulate_waypoints(scenario, waypoints, move_time=args.move_time, dwell=args.dwell,
                             believed_tool_length=believed, record=args.record,
                             believed_grasp=grasp)
    errors = [r.position_error for r in run.results]
    return {"scenario": str(args.scenario), "tool_length_m": scenario.tool.length,
            "believed_tool_length_m": believed or scenario.tool.length, **measured,
            "waypoints": [r.as_dict() for r in run.results],
            "max_position_error_m": max(errors), "mean_position_error_m": float(np.mean(errors)),
            "sim_time_s": run.sim_time, "wall_time_s": time.perf_counter() - start,
            "recording": str(run.recording) if run.recording else None}


def cmd_generate_models(args) -> dict:
    from drake_tooluse.baxter_model import baxter_urdf, write_models

    target = REPO_DIR / "models" / "baxter" / "baxter.urdf"
    if args.check:
        current = target.is_file() and target.read_text() == baxter_urdf()
        if not current:
            raise UsageError(f"{target} is out of date; run `drake-tooluse generate-models`")
        return {"current": True, "path": str(target)}
    return {"written": str(write_models(REPO_DIR / "models"))}


def cmd_render_diagrams(args) -> dict:
    from drake_tooluse.diagrams import render_all

    return render_all(DIAGRAMS_DIR, check=args.check)


def cmd_train(args) -> dict:
    from drake_tooluse.train import resolve_config, train

    if args.resume is not None:
        out_dir = args.resume
        if args.out is not None and args.out != args.resume:
            raise UsageError("give --resume DIR alone (it is the run directory), not with --out")
    elif args.out is None:
        raise UsageError("give --out DIR for a new run, or --resume DIR to continue one")
    else:
        out_dir = args.out
    overrides = json.loads(args.hyperparams) if args.hyperparams else None
    config = resolve_config(args.env, args.algo, args.timesteps, args.n_envs, args.seed,
                            init_from=str(args.init_from) if args.init_from else None,
                            overrides=overrides)
    command = "drake-tooluse " + shlex.join(sys.argv[1:]) if sys.argv else ""
    return train(config, out_dir, resume=args.resume is not None,
                 progress_bar=not args.no_progress and sys.stderr.isatty(), command=command)


def cmd_evaluate(args) -> dict:
    from dataclasses import asdict

    from drake_tooluse.train import evaluate

    env_kwargs = json.loads(args.env_kwargs) if args.env_kwargs else None
    result = asdict(evaluate(args.policy, args.env, args.episodes, args.seed, env_kwargs))
    if not args.per_episode:
        result.pop("per_episode")
    return result


def cmd_sweep(args) -> dict:
    from drake_tooluse.sweep import results_table, sweep

    overrides = json.loads(args.hyperparams) if args.hyperparams else None
    rows = sweep(args.algos, args.envs, args.seeds, args.timesteps, args.out,
                 address=args.address, num_cpus=args.num_cpus, overrides=overrides,
                 episodes=args.episodes)
    return {"runs": rows, "table": results_table(rows)}


def cmd_trajectory(args) -> dict:
    from drake_tooluse.scenario import check_tool_length
    from drake_tooluse.trajectory import extract, plot_extraction

    length = check_tool_length(args.tool_length, "--tool-length")
    start = time.perf_counter()
    ex = extract(args.policy, args.episodes, args.seed, args.window, length, align=args.align)
    path = ex.reachability.kept.save(args.out / "trajectory.npz")
    figure = plot_extraction(ex, args.out / "trajectory.png")
    r = ex.reachability
    return {"episodes": args.episodes, "successes": ex.successes, "steps": r.poses,
            "reachable_before_filter": r.poses, "reachable_after_filter": r.reachable,
            "dropped_steps": r.dropped_indices, "trajectory": str(path), "figure": str(figure),
            "wall_time_s": time.perf_counter() - start}


def cmd_export_csv(args) -> dict:
    from drake_tooluse.scenario import RobotConfig, check_tool_length
    from drake_tooluse.trajectory import TipTrajectory, export_baxter_csv, filter_reachable
    from drake_tooluse.validation import check_in_range

    length = check_tool_length(args.tool_length, "--tool-length")
    scale = check_in_range(args.time_scale, 0.1, 100.0, "--time-scale")
    traj = TipTrajectory.load(args.trajectory)
    report = filter_reachable(traj, length)
    if report.dropped_indices:
        times = [round(float(traj.times[i]), 3) for i in report.dropped_indices[:10]]
        raise ValueError(f"{len(report.dropped_indices)} of {report.poses} poses of "
                         f"{str(args.trajectory)!r} are unreachable with a {length} m tool under "
                         f"the conservative joint limits (at t = {times} s …); nothing written")
    times = (report.kept.times - report.kept.times[0]) * scale
    path = export_baxter_csv(args.out, times, report.joint_positions, RobotConfig().left_arm_q)
    return {"csv": str(path), "rows": len(times), "duration_s": float(times[-1])}


def _cmd_measure(args) -> dict:
    from drake_tooluse.measure import cmd_measure

    return cmd_measure(args)


def _cmd_transfer(args) -> dict:
    from drake_tooluse.transfer import cmd_transfer

    return cmd_transfer(args)


def _cmd_demo(args) -> dict:
    from drake_tooluse.demo import cmd_demo

    return cmd_demo(args)


def _print_human(name: str, out: dict) -> None:
    if name == "fk":
        t = out["tip"]
        print(f"tool tip in world: position {np.round(t['position_m'], 5).tolist()} m, "
              f"quaternion wxyz {np.round(t['quaternion_wxyz'], 5).tolist()}, "
              f"rpy {np.round(t['rpy_rad'], 5).tolist()} rad")
    elif name == "ik":
        print(f"success {out['success']}  q {np.round(out['q'], 5).tolist()} rad")
        print(f"tip error {out['position_error_m'] * 1e3:.4g} mm, "
              f"{out['orientation_error_rad']:.3g} rad; solve {out['solve_time_s'] * 1e3:.2f} ms"
              f" ({out['attempts']} attempt(s))")
    elif name == "simulate":
        for i, w in enumerate(out["waypoints"]):
            print(f"waypoint {i}: target {np.round(w['target_m'], 4).tolist()} m, "
                  f"tip error {w['position_error_m'] * 1e3:.3g} mm, "
                  f"{w['orientation_error_rad']:.2e} rad, IK ok {w['ik_success']}")
        print(f"max tip error {out['max_position_error_m'] * 1e3:.3g} mm; "
              f"{out['sim_time_s']:.1f} s simulated in {out['wall_time_s']:.1f} s")
        if out["recording"]:
            print(f"recording: {out['recording']}")
    elif name == "measure":
        from drake_tooluse.measure import format_measurement

        print(format_measurement(out))
    elif name == "transfer":
        from drake_tooluse.transfer import format_transfer

        print(format_transfer(out))
    elif name == "demo":
        from drake_tooluse.demo import format_demo

        print(format_demo(out))
    elif name == "sweep":
        print(out["table"], end="")
    elif name == "evaluate":
        print(f"{out['episodes']} episodes from seed {out['seed']}: final box-goal distance "
              f"mean {out['final_box_to_goal_mean_m'] * 100:.2f} cm, median "
              f"{out['final_box_to_goal_median_m'] * 100:.2f} cm, std "
              f"{out['final_box_to_goal_std_m'] * 100:.2f} cm; success "
              f"{out['success_rate'] * 100:.0f} %; box travel {out['box_travel_mean_m'] * 100:.1f}"
              f" cm; episode length {out['episode_length_mean']:.1f}; tool touched the box in "
              f"{out['tool_touched_rate'] * 100:.0f} %, gripper in "
              f"{out['gripper_touched_rate'] * 100:.0f} %")
    else:
        print(json.dumps(out, indent=2))


COMMANDS = {"fk": cmd_fk, "ik": cmd_ik, "simulate": cmd_simulate,
            "generate-models": cmd_generate_models, "render-diagrams": cmd_render_diagrams,
            "train": cmd_train, "evaluate": cmd_evaluate, "sweep": cmd_sweep,
            "trajectory": cmd_trajectory, "export-csv": cmd_export_csv, "measure": _cmd_measure,
            "transfer": _cmd_transfer, "demo": _cmd_demo}


def make_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="drake-tooluse", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("fk", help="tool-tip pose in the world at given right-arm joint angles")
    _add_tool_args(p)
    p.add_argument("--q", type=float, nargs="+", required=True, metavar="RAD",
                   help="7 right-arm joint angles s0 s1 e0 e1 w0 w1 w2 (rad)")

    p = sub.add_parser("ik", help="joint angles that put the tool tip at a pose")
    _add_tool_args(p)
    p.add_argument("--position", type=float, nargs="+", required=True, metavar="M",
                   help="tip position x y z in the world (Baxter base) frame, m")
    p.add_argument("--rpy", type=float, nargs="+", metavar="RAD",
                   help="tip orientation roll pitch yaw, rad (default: tool pointing down)")
    p.add_argument("--quaternion", type=float, nargs="+", metavar="Q",
                   help="tip orientation as a quaternion w x y z (instead of --rpy)")
    p.add_argument("--seed-q", type=float, nargs="+", metavar="RAD",
                   help="warm start: 7 joint angles (rad)")
    p.add_argument("--measure", action="store_true",
                   help="measure the tool with the head camera first (the world's tool: "
                        "--scenario, with --tool-length as its true length) and solve for the "
                        "measured tool (length and grasp along it)")
    p.add_argument("--scenario", type=Path, default=DEFAULT_SCENARIO,
                   help="scenario YAML (with --measure)")

    p = sub.add_parser("simulate", help="move the tool tip through waypoints in the dynamic "
                                        "simulation with the IK in the loop")
    add_scenario_args(p)
    p.add_argument("--believed-tool-length", type=float, metavar="L",
                   help="tool length the robot model believes (m); default the true one")
    p.add_argument("--tip-waypoints", nargs="+", required=True, metavar="X,Y,Z[,R,P,Y]",
                   help="tip waypoints in m (and rad); the tool points down if no rpy")
    p.add_argument("--move-time", type=float, default=1.0, help="s per move (default 1.0)")
    p.add_argument("--dwell", type=float, default=1.5, help="s held at each waypoint (1.5)")
    p.add_argument("--record", type=Path, metavar="HTML",
                   help="write a Meshcat recording (standalone HTML)")
    p.add_argument("--measure", action="store_true",
                   help="measure the tool with the head camera first; the robot model then "
                        "holds the measured length and grasp along the tool")

    from drake_tooluse.registration import ENV_IDS

    p = sub.add_parser("train", help="train a policy with stable-baselines3 / sb3-contrib")
    p.add_argument("--env", default="drake_tooluse/ToolPush-v0", help=f"one of {list(ENV_IDS)}")
    p.add_argument("--algo", default="ppo", help="ppo, a2c, ddpg or trpo")
    p.add_argument("--timesteps", type=int, default=1_250_000)
    p.add_argument("--n-envs", type=int, help="parallel envs (default from the YAML)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", type=Path, help="new run directory")
    p.add_argument("--resume", type=Path, metavar="DIR", help="continue the run in DIR")
    p.add_argument("--init-from", type=Path, metavar="POLICY",
                   help="start from a trained policy directory (fine-tuning)")
    p.add_argument("--hyperparams", metavar="JSON",
                   help='override YAML hyperparameters, e.g. \'{"learning_rate": 1e-4}\'')
    p.add_argument("--no-progress", action="store_true", help="no progress bar")

    p = sub.add_parser("evaluate", help="evaluate a policy directory over seeded episodes")
    p.add_argument("--policy", type=Path, required=True, help="policy directory")
    p.add_argument("--env", help="env id (default: the one it was trained on)")
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--env-kwargs", metavar="JSON", help="override env kwargs")
    p.add_argument("--per-episode", action="store_true", help="include each episode")

    p = sub.add_parser("sweep", help="a grid of runs (algos x envs x seeds) on Ray "
                                     "(pip install -e '.[cluster]')")
    p.add_argument("--algos", nargs="+", default=["ppo"], help="ppo a2c ddpg trpo")
    p.add_argument("--envs", nargs="+", default=["drake_tooluse/ToolPush-v0"])
    p.add_argument("--seeds", type=int, nargs="+", default=[0])
    p.add_argument("--timesteps", type=int, default=300_000)
    p.add_argument("--out", type=Path, required=True, help="directory for the runs and table")
    p.add_argument("--address", help="join this Ray cluster (default: a local one)")
    p.add_argument("--num-cpus", type=int, help="CPUs of the local Ray (default: all)")
    p.add_argument("--hyperparams", metavar="JSON", help="override YAML hyperparameters")
    p.add_argument("--episodes", type=int, default=20, help="evaluation episodes per run")

    p = sub.add_parser("trajectory", help="record a policy's episodes and average them into a "
                                          "tool-tip trajectory (the paper's transfer input)")
    p.add_argument("--policy", type=Path, required=True, help="policy directory")
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--window", type=int, default=5, help="smoothing window (odd, steps)")
    p.add_argument("--align", default="start",
                   help="'start' (the paper's: step by step from the start) or 'contact' "
                        "(from the tool's first touch of the box)")
    p.add_argument("--tool-length", type=float, default=0.175,
                   help="tool for the reachability filter (m)")
    p.add_argument("--out", type=Path, required=True, help="directory for trajectory.npz/.png")

    p = sub.add_parser("export-csv", help="a tool-tip trajectory as a Baxter SDK playback CSV")
    p.add_argument("--trajectory", type=Path, required=True, help="trajectory .npz")
    p.add_argument("--tool-length", type=float, required=True, help="the tool held (m)")
    p.add_argument("--out", type=Path, required=True, help="CSV file to write")
    p.add_argument("--time-scale", type=float, default=1.0,
                   help="stretch time by this factor (slower is safer)")

    from drake_tooluse.measure import add_measure_parser

    add_measure_parser(sub)

    from drake_tooluse.transfer import add_transfer_parser

    add_transfer_parser(sub)

    from drake_tooluse.demo import add_demo_parser

    add_demo_parser(sub)

    p = sub.add_parser("generate-models", help="write models/baxter/baxter.urdf")
    p.add_argument("--check", action="store_true", help="only check it is current")

    p = sub.add_parser("render-diagrams", help="render each diagram's block diagram to "
                                               "diagrams/*.dot and .svg")
    p.add_argument("--check", action="store_true", help="only check the .dot files are current")

    for p in sub.choices.values():
        p.add_argument("--json", action="store_true", help="print JSON")
    return parser


def main(argv=None) -> int:
    args = make_parser().parse_args(argv)
    try:
        out = COMMANDS[args.command](args)
    except (ValueError, FileNotFoundError, FileExistsError, json.JSONDecodeError,
            RuntimeError) as e:
        if getattr(args, "json", False):
            print(json.dumps({"error": str(e)}))
        print(f"drake-tooluse {args.command}: error: {e}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        _print_human(args.command, out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
