"""What makes the paper's open-loop transfer push the box to the goal, or not:
one recording of a policy's episodes, several ways of making one trajectory of them, each
replayed open loop in the nominal simulation and in reality (diagrams/reality.yaml) with the
paper's tools and longer ones the policy never saw (it trained with 0.175 m), as `drake-tooluse
transfer --mode open-loop` replays its trajectory.

    python benchmarks/open_loop_variants.py [--episodes 100] [--runs 10] [--tools M ...]
                                            [--variants NAME ...] [--tilts DEG ...]
                                            [--offsets CM ...] [--calibration-draws N]
                                            [--out FILE | --update-docs]

Variants, each changing one thing of the one above it:

  paper        the paper's: where the tip got at each step, the per-step mean of the episodes
               from their start, each to the step limit, where the env judges it (an episode
               that ends early, by a simulation failure, holding its last pose); smoothed over
               5 steps, the poses the IK reaches under the conservative limits kept
  commanded    the tip poses each step commanded instead (Baxter's arm lags them by ~2 cm)
  box-frame    each episode shifted by where its box started before averaging, and the replay
               by where the run's box starts: in reality as the robot's hand camera measures it
               at home (`builders.box_measurement`), in the nominal world the truth
  medoid       the one episode nearest all the others (mean tip distance, in the box frame)
               instead of their mean
  centred      box-frame, moved across the push so that the tool runs through the box's centre
               line while it pushes (the mean pushes ~0.4 cm to one side)
  line-contact centred, the tool tilted about the push direction (its tip leaning away from
               the robot) about the point of its axis at the box's mid-height, so that its
               shaft, not its point, meets the box's face: a line contact, which pushes stably
               open loop where a point does not (Lynch & Mason 1996); ramped in over the
               approach, 30 degrees or the steepest shallower tilt the IK follows without a
               jump for every box start (from the posture seed or the start of the branch its
               path ends on), then moved across the push to the offset that pushes best over
               `--calibration-draws` randomized replays in the nominal simulation
               (`drake_tooluse.experiments.line_contact`: what `drake-tooluse transfer --mode
               open-loop` replays by default)

`--tilts DEG ...` adds a line-contact row per tilt (that tilt, whether the IK follows it or
not): how steep is best. `--offsets CM ...` adds a line-contact row per offset: the centred,
tilted trajectory moved that far across the push (+: to the left of the push direction): how
far off the box's centre line an open-loop push may run. Those rows are not calibrated (the
geometric centring, as `--calibration-draws 0`).

The policy acts deterministically in the nominal env with randomized starts (seeds 0, 1, ...);
each replay run i draws the reality of `drake-tooluse transfer` run i (seed + i), the robot's
tool measured by the head camera and the box's start by the hand camera. Prints a Markdown table
and writes it as JSON to a new runs/open_loop_variants-<time>/open_loop_variants.json (or
--out); `--update-docs` writes docs/results/open_loop_variants.json, which docs/TRANSFER.md quotes.
"""

import argparse
import sys
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np

from drake_tooluse.builders.box_measurement import measure_box_start
from drake_tooluse.builders.measurement import measure_belief
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.choices import CALIBRATION_DRAWS
from drake_tooluse.experiments.line_contact import (
    TILTS_DEG,
    centred,
    joints_at_limit,
    line_contact_for_task,
    side_of,
)
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.experiments.trajectory_extraction import (
    average_episodes,
    filter_reachable,
    pad_episodes,
    shifted,
    smooth,
)
from drake_tooluse.experiments.transfer import run_worlds
from drake_tooluse.files import atomic_write_json
from drake_tooluse.learning.evaluate import make_policy_env, run_episode
from drake_tooluse.limits import MAX_CALIBRATION_DRAWS, MAX_EPISODES, MAX_RUNS
from drake_tooluse.paths import DEFAULT_SCENARIO, REALITY_SCENARIO, TRANSFER_POLICY
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import check_tool_length
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.tasks.push.diagram import run_open_loop
from drake_tooluse.validation import check_in_range, check_int, check_seed
from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import initial_box_pose

OUTPUT = BenchmarkOutput(Path(__file__))
ACHIEVED, COMMANDED = slice(0, 7), slice(7, 14)


class Variant(NamedTuple):
    """How one variant makes its trajectory (see the module docstring)."""

    columns: slice  # the recorded tip poses: ACHIEVED or COMMANDED
    box_frame: bool = False
    medoid: bool = False
    centred: bool = False
    line_contact: bool = False


VARIANTS = {
    "paper": Variant(ACHIEVED),
    "commanded": Variant(COMMANDED),
    "box-frame": Variant(COMMANDED, box_frame=True),
    "medoid": Variant(COMMANDED, box_frame=True, medoid=True),
    "centred": Variant(COMMANDED, box_frame=True, centred=True),
    "line-contact": Variant(COMMANDED, box_frame=True, line_contact=True),
}


def _pose(X) -> np.ndarray:
    return np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()])


class _Recorder:
    """`run_episode`'s on_step: rows [achieved tip pose (7), commanded tip pose (7)] (row 0 the
    start), the step of the first success (None: none) and the box's start (3)."""

    def __init__(self, env):
        self.env, self.rows, self.success, self.box = env.unwrapped, [], None, None

    def __call__(self, step: int, info: dict) -> None:
        u = self.env
        if step == 0:
            plant_context = u.world.plant.GetMyContextFromRoot(u.simulator.get_context())
            self.box = u.world.box.EvalPoseInWorld(plant_context).translation().copy()
        self.rows.append(
            np.concatenate([_pose(u.believed_poses()[0]), _pose(u.commanded_tip_pose())])
        )
        if step > 0 and self.success is None and info["is_success"]:
            self.success = step


def record(policy_dir, episodes: int):
    """Each episode run to the step limit (`_Recorder`'s rows, first success and box start),
    and the control period."""
    policy, env = make_policy_env(policy_dir)
    recorded = []
    for ep in range(episodes):
        recorder = _Recorder(env)
        run_episode(env, policy, ep, on_step=recorder)
        recorded.append((np.array(recorder.rows), recorder.success, recorder.box))
    period = env.unwrapped.scenario.control.control_period
    env.close()
    return recorded, period


def trajectory(recorded, period: float, variant: str, nominal_box: np.ndarray) -> TipTrajectory:
    """One trajectory of the recorded episodes, each to the step limit, in the nominal box
    start's frame if the variant is in the box frame (see the module docstring). Not cut at
    the first success: a policy reaches it at the success threshold (the box ~18 of its 20 cm,
    the tip ~3 cm from the box's centre) and pushes on to the goal after it; cut there, the
    mean push would end on the threshold and half its replays stop short of it."""
    columns, box_frame, medoid, _, _ = VARIANTS[variant]
    episodes = []
    for rows, _, box in recorded:
        ep = rows[:, columns].copy()
        if box_frame:
            ep[:, :2] -= (box - nominal_box)[:2]
        episodes.append(ep)
    stacked = pad_episodes(episodes)
    if medoid:
        tips = stacked[:, :, :3]
        distance = np.linalg.norm(tips[:, None] - tips[None, :], axis=-1).mean(axis=-1)
        best = stacked[int(np.argmin(distance.sum(axis=1)))]
        traj = TipTrajectory(np.arange(len(best)) * period, best[:, :3], best[:, 3:])
    else:
        traj = average_episodes(stacked[:, :, :3], stacked[:, :, 3:], period)
    return smooth(traj, 5)


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--policy", type=Path, default=TRANSFER_POLICY)
    ap.add_argument("--episodes", type=int, default=100, help="recorded episodes")
    ap.add_argument("--runs", type=int, default=10, help="replay runs per tool and world")
    ap.add_argument("--seed", type=int, default=0, help="the first replay run's seed")
    ap.add_argument(
        "--tools", type=float, nargs="+", default=[*PAPER_TOOL_LENGTHS, 0.25, 0.3], help="m"
    )
    ap.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    ap.add_argument(
        "--tilts", type=int, nargs="+", default=[], help="a line-contact row at each (deg)"
    )
    ap.add_argument(
        "--offsets", type=float, nargs="+", default=[], help="a line-contact row at each (cm)"
    )
    ap.add_argument(
        "--calibration-draws",
        type=int,
        default=CALIBRATION_DRAWS,
        help="line-contact row: nominal replays per offset across the push (0: not calibrated)",
    )
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    args.out = OUTPUT.path(args)
    try:  # bad input: one line naming the value, not a traceback
        check_int(args.episodes, 1, MAX_EPISODES, "--episodes")
        check_int(args.runs, 1, MAX_RUNS, "--runs")
        check_int(args.calibration_draws, 0, MAX_CALIBRATION_DRAWS, "--calibration-draws")
        check_seed(args.seed, "--seed", args.runs)
        for tool in args.tools:
            check_tool_length(tool, "--tools")
        for tilt in args.tilts:
            check_int(tilt, 0, 80, "--tilts")
        for offset in args.offsets:
            check_in_range(offset, -5.0, 5.0, "--offsets", unit="cm")
    except ValueError as e:
        ap.error(str(e))
    try:  # a tool the study cannot use (no pose reachable, no box in view): one line too
        study(args)
    except ValueError as e:
        ap.exit(1, f"{ap.prog}: {e}\n")


def study(args) -> None:
    """Records, builds every variant's trajectory, replays them, prints and writes the table."""
    start = time.perf_counter()
    recorded, period = record(args.policy, args.episodes)
    nominal_s, reality_s = load_scenario(DEFAULT_SCENARIO), load_scenario(REALITY_SCENARIO)
    nominal_box = initial_box_pose(nominal_s).translation()
    successes = sum(success is not None for _, success, _ in recorded)
    print(f"recorded {args.episodes} episodes ({successes} reached the goal)", flush=True)
    # (tool, run) -> (nominal scenario, reality scenario, measured belief, measured box start)
    worlds, box_errors = {}, []
    for tool in args.tools:
        for i in range(args.runs):
            nominal, reality, _ = run_worlds(nominal_s, reality_s, tool, args.seed + i)
            believed, _ = measure_belief(reality, seed=args.seed + i)
            box_xy = measure_box_start(reality, believed).p_WB_xy
            box_errors.append(np.linalg.norm(box_xy - initial_box_pose(reality).translation()[:2]))
            worlds[tool, i] = (nominal, reality, believed, box_xy)
    print(f"box start measured within {max(box_errors) * 1000:.1f} mm", flush=True)
    push_direction = np.asarray(nominal_s.goal_offset, float)
    box_size = nominal_s.box.size
    # (variant, the tilts its line contact may take: None for the variant's own, an offset
    # across the push in m)
    specs = [(v, None, 0.0) for v in args.variants]
    specs += [("line-contact", (t,), 0.0) for t in args.tilts]
    specs += [("line-contact", None, o / 100) for o in args.offsets]
    left = side_of(push_direction)[:2]
    rows = []
    for variant, tilts, offset in specs:
        v = VARIANTS[variant]
        base = trajectory(recorded, period, variant, nominal_box)
        if v.centred:
            base = centred(base, push_direction, nominal_box, box_size)
        for tool in args.tools:
            if v.line_contact:
                draws = args.calibration_draws if tilts is None and not offset else 0
                contact = line_contact_for_task(
                    base, tool, nominal_s, tilts or TILTS_DEG, calibration_draws=draws
                )
                kept, tilt_deg, followed = contact.trajectory, contact.tilt_deg, contact.followed
                kept = shifted(kept, offset * left) if offset else kept
                at_limit = contact.joints_at_limit
            else:
                report = filter_reachable(base, tool)
                kept, tilt_deg, followed = report.kept, 0, True
                at_limit = joints_at_limit(report.joint_positions)
            runs = {"nominal": [], "reality": []}
            for i in range(args.runs):
                nominal, reality, believed, box_xy = worlds[tool, i]
                knows = RobotBelief(tool, (0.0, nominal.tool.grasp_offset_along))
                for world, scenario, belief, p_WBox_xy in (
                    ("nominal", nominal, knows, initial_box_pose(nominal).translation()[:2]),
                    ("reality", reality, believed, box_xy),
                ):
                    dxy = p_WBox_xy - nominal_box[:2]
                    replay = shifted(kept, dxy) if v.box_frame else kept
                    run = run_open_loop(scenario, replay, belief)
                    moved = run.object_path[-1] - run.object_path[0]
                    runs[world].append(
                        {
                            "success": bool(run.success),
                            "object_travel_m": float(run.object_travel),
                            "final_object_to_goal_m": float(run.final_object_to_goal),
                            "final_tip_to_object_m": float(run.metrics.tip_to_object),
                            "box_dx_m": float(moved[0]),  # across the push (+y)
                            "sim_error": bool(run.sim_error),
                        }
                    )
            row = {"variant": variant, "tool_length_m": tool, "poses": len(base)}
            row["row"] = variant if tilts is None else f"{variant} at {tilts[0]} deg"
            if offset:
                row["row"] += f" {offset * 100:+g} cm across"
            row["offset_m"] = offset
            row["poses_kept"] = len(kept)
            row["tilts_tried_deg"] = list(tilts or TILTS_DEG) if v.line_contact else []
            row["tilt_deg"], row["tilt_followed"] = tilt_deg, followed
            row["joints_at_limit"] = at_limit
            if v.line_contact:
                row["line_contact"] = contact.as_dict()
            for world, rs in runs.items():
                row[world] = {
                    "at_goal": sum(r["success"] for r in rs),
                    "runs": len(rs),
                    "object_travel_mean_m": float(np.mean([r["object_travel_m"] for r in rs])),
                    "final_object_to_goal_mean_m": float(
                        np.mean([r["final_object_to_goal_m"] for r in rs])
                    ),
                    "box_across_mean_abs_m": float(np.mean([abs(r["box_dx_m"]) for r in rs])),
                    "per_run": rs,
                }
            rows.append(row)
            n, r = row["nominal"], row["reality"]
            print(
                f"{row['row']} {tool} m (tilt {tilt_deg}°, joints at a limit: "
                f"{', '.join(row['joints_at_limit']) or 'none'}): at the goal {n['at_goal']}/{n['runs']} nominal, "
                f"{r['at_goal']}/{r['runs']} reality; travel {n['object_travel_mean_m'] * 100:.1f}"
                f" / {r['object_travel_mean_m'] * 100:.1f} cm",
                flush=True,
            )
    atomic_write_json(
        args.out,
        {
            "command": f"python benchmarks/open_loop_variants.py --episodes {args.episodes} "
            f"--runs {args.runs} --seed {args.seed} --tools "
            + " ".join(f"{t:g}" for t in args.tools)
            + ("" if args.variants == list(VARIANTS) else " --variants " + " ".join(args.variants))
            + (" --tilts " + " ".join(map(str, args.tilts)) if args.tilts else "")
            + (" --offsets " + " ".join(f"{o:g}" for o in args.offsets) if args.offsets else "")
            + (
                f" --calibration-draws {args.calibration_draws}"
                if args.calibration_draws != CALIBRATION_DRAWS
                else ""
            ),
            "policy": "models/policies/ppo_toolpush_tip"
            if args.policy == TRANSFER_POLICY
            else str(args.policy),
            "episodes_recorded": args.episodes,
            "episodes_at_goal": successes,
            "box_start_error_max_m": float(max(box_errors)),
            "rows": rows,
            "wall_time_s": time.perf_counter() - start,
        },
    )
    print(
        "\n| variant | tool (m) | at the goal nominal / reality | box travel nominal / reality "
        "(cm) | reality / nominal | final box–goal reality (cm) | box off the push line, "
        "reality (cm) | the paper's two tools' reality travel differ (cm) |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in rows:
        n, r = row["nominal"], row["reality"]
        pair = [
            x["reality"]["object_travel_mean_m"]
            for x in rows
            if x["row"] == row["row"] and x["tool_length_m"] in PAPER_TOOL_LENGTHS
        ]
        differ = f"{(max(pair) - min(pair)) * 100:.2f}" if len(pair) == 2 else "—"
        nominal_travel = n["object_travel_mean_m"]
        ratio = (
            f"{r['object_travel_mean_m'] / nominal_travel * 100:.0f} %" if nominal_travel else "—"
        )
        label = row["row"]
        if row["tilt_deg"] and not label.startswith(f"{row['variant']} at"):  # the tilt it chose
            label += f" ({row['tilt_deg']}°)"
        calibrated = row.get("line_contact", {}).get("across_offset_m")
        if calibrated:  # where the nominal replays put it across the push
            label += f" ({calibrated * 1000:+.0f} mm across)"
        if row["tilts_tried_deg"] and not row["tilt_followed"]:
            label += " (the IK jumps)"
        print(
            f"| {label} | {row['tool_length_m']:.3f} | {n['at_goal']} / {r['at_goal']} of "
            f"{r['runs']} | {n['object_travel_mean_m'] * 100:.1f} / {r['object_travel_mean_m'] * 100:.1f}"
            f" | {ratio} | "
            f"{r['final_object_to_goal_mean_m'] * 100:.1f} | {r['box_across_mean_abs_m'] * 100:.1f} | "
            f"{differ} |"
        )
    print(f"\nwrote {args.out} ({(time.perf_counter() - start) / 60:.1f} min)")


if __name__ == "__main__":
    sys.exit(run_script(main))
