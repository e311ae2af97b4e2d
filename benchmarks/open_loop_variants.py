"""What makes the paper's open-loop transfer push the box to the goal, or not (issue 13, item 2):
one recording of a policy's episodes, several ways of making one trajectory of them, each
replayed open loop in the nominal simulation and in reality (diagrams/reality.yaml) with the
paper's tools and longer ones the policy never saw (it trained with 0.175 m), as `drake-tooluse
transfer --mode open-loop` replays its trajectory.

    python benchmarks/open_loop_variants.py [--episodes 100] [--runs 10] [--tools M ...]
                                            [--variants NAME ...] [--out FILE]

Variants, each changing one thing of the one above it:

  paper        the paper's: where the tip got at each step, the per-step mean of the episodes
               from their start (an episode that ends early holds its last pose), smoothed over
               5 steps, the poses the IK reaches under the conservative limits kept
  commanded    the tip poses each step commanded instead (Baxter's arm lags them by ~2 cm)
  box-frame    each episode shifted by where its box started before averaging, and the replay
               by where the run's box starts: in reality as the robot's hand camera measures it
               at home (`diagrams.box_measurement`), in the nominal world the truth
  medoid       the one episode nearest all the others (mean tip distance, in the box frame)
               instead of their mean
  full-length  box-frame, with the episodes recorded past their success to the 100-step limit
               (the paper's Fetch episodes had no early end)
  line-contact box-frame, the tool tilted about the push direction (its tip leaning away from
               the robot) about the point of its axis at the box's mid-height, so that its
               shaft, not its point, meets the box's face: a line contact, which pushes stably
               open loop where a point does not (Lynch & Mason 1996). The tilt is ramped in over
               the first RAMP_STEPS steps (the approach, before the contact) and chosen per tool:
               the steepest of TILTS_DEG at which the IK reaches every pose under the
               conservative limits with no joint step over MAX_JOINT_STEP (else the one that
               reaches the most poses, flagged `tilt_reachable: false`)

The policy acts deterministically in the nominal env with randomized starts (seeds 0, 1, ...);
each replay run i draws the reality of `drake-tooluse transfer` run i (seed + i), the robot's
tool measured by the head camera and the box's start by the hand camera. Prints a Markdown table and writes
docs/results/open_loop_variants.json (or --out).
"""

import argparse
import time
from pathlib import Path
from typing import NamedTuple

import numpy as np
from pydrake.common.eigen_geometry import AngleAxis, Quaternion
from pydrake.math import RotationMatrix

from drake_tooluse.diagrams.box_measurement import measure_box_start
from drake_tooluse.diagrams.measurement import measure_belief
from drake_tooluse.experiments.trajectory import (
    average_episodes,
    filter_reachable,
    pad_episodes,
    smooth,
)
from drake_tooluse.experiments.transfer import run_open_loop, run_worlds
from drake_tooluse.files import atomic_write_json
from drake_tooluse.learning.evaluate import make_policy_env, run_episode
from drake_tooluse.paths import DEFAULT_SCENARIO, REALITY_SCENARIO
from drake_tooluse.robot.baxter_model import (
    Q_LOWER_CONSERVATIVE,
    Q_UPPER_CONSERVATIVE,
    RIGHT_ARM_JOINTS,
)
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.robot.tool import check_tool_length
from drake_tooluse.systems.tip_trajectory import TipTrajectory
from drake_tooluse.validation import check_int, check_seed
from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import initial_box_pose

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "docs" / "results" / "open_loop_variants.json"
POLICY = Path("models") / "policies" / "ppo_toolpush_tip"
ACHIEVED, COMMANDED = slice(0, 7), slice(7, 14)


class Variant(NamedTuple):
    """How one variant makes its trajectory (see the module docstring)."""

    columns: slice  # the recorded tip poses: ACHIEVED or COMMANDED
    box_frame: bool = False
    medoid: bool = False
    full_length: bool = False
    line_contact: bool = False


VARIANTS = {
    "paper": Variant(ACHIEVED),
    "commanded": Variant(COMMANDED),
    "box-frame": Variant(COMMANDED, box_frame=True),
    "medoid": Variant(COMMANDED, box_frame=True, medoid=True),
    "full-length": Variant(COMMANDED, box_frame=True, full_length=True),
    "line-contact": Variant(COMMANDED, box_frame=True, line_contact=True),
}
TILTS_DEG = (60, 55, 50, 45, 40, 35)  # tried steepest first
RAMP_STEPS = 10  # the recorded tip first meets the box ~12-16 steps in
MAX_JOINT_STEP = 0.3  # rad per control step (7.5 rad/s): more is a jump between IK branches


def _pose(X) -> np.ndarray:
    return np.concatenate([X.translation(), X.rotation().ToQuaternion().wxyz()])


class _Recorder:
    """`run_episode`'s on_step: rows [achieved tip pose (7), commanded tip pose (7)] (row 0 the
    start), the row of the first success (None: none) and the box's start (3)."""

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
    """Each episode run on to the step limit (`_Recorder`'s rows, first success and box start),
    and the control period."""
    policy, env = make_policy_env(policy_dir)
    recorded = []
    for ep in range(episodes):
        recorder = _Recorder(env)
        run_episode(env, policy, ep, on_step=recorder, to_time_limit=True)
        recorded.append((np.array(recorder.rows), recorder.success, recorder.box))
    period = env.unwrapped.scenario.control.control_period
    env.close()
    return recorded, period


def trajectory(recorded, period: float, variant: str, nominal_box: np.ndarray) -> TipTrajectory:
    """One trajectory of the recorded episodes, in the nominal box start's frame if the
    variant is in the box frame (see the module docstring)."""
    columns, box_frame, medoid, full_length, _ = VARIANTS[variant]
    episodes = []
    for rows, success, box in recorded:
        ep = rows[: None if full_length or success is None else success + 1, columns].copy()
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


def shifted(traj: TipTrajectory, dxy) -> TipTrajectory:
    return TipTrajectory(traj.times, traj.positions + [dxy[0], dxy[1], 0.0], traj.quaternions)


def tilted(traj: TipTrajectory, angle: float, push_direction, p_WB) -> TipTrajectory:
    """The trajectory with the tool turned by `angle` (rad, ramped in over RAMP_STEPS) about
    the horizontal `push_direction`, about the point of the tool's axis at the height of the box
    centre `p_WB`, the tip leaning away from the robot (W's origin, Baxter's base): to the side
    of the push line that points away from the base, chosen once for the whole trajectory."""
    u = np.array([push_direction[0], push_direction[1], 0.0])
    u /= np.linalg.norm(u)
    # A turn by +angle about u swings a downward tool's tip along side = z × u (for small
    # angles, d' = d + angle u × d with d = -z); lean to whichever of ±side points away from
    # the base.
    side = np.cross([0.0, 0.0, 1.0], u)[:2]
    away = float(side @ p_WB[:2]) / np.linalg.norm(p_WB[:2])
    if abs(away) < 0.1:
        raise ValueError(
            f"push direction {list(np.round(push_direction, 3))} runs (nearly) towards or away "
            "from the robot: no side of it leans away from the robot (need its angle to the "
            "line from the base to the box over ~6 deg)"
        )
    sign = 1.0 if away > 0 else -1.0
    positions, quaternions = [], []
    for k, (p_WT, q) in enumerate(zip(traj.positions, traj.quaternions)):
        R_WT = RotationMatrix(Quaternion(q))
        tool_axis = R_WT.matrix()[:, 2]  # T's z: along the tool, towards the tip
        if tool_axis[2] > -0.1:
            raise ValueError(f"pose {k}: the tool does not point down (axis {tool_axis.round(3)})")
        R_turn = RotationMatrix(AngleAxis(sign * angle * min(1.0, k / RAMP_STEPS), u))
        p_WPivot = p_WT + (p_WB[2] - p_WT[2]) / tool_axis[2] * tool_axis
        positions.append(p_WPivot + R_turn.matrix() @ (p_WT - p_WPivot))
        quaternions.append((R_turn @ R_WT).ToQuaternion().wxyz())
    return TipTrajectory(traj.times, np.array(positions), np.array(quaternions))


def joints_at_limit(q: np.ndarray) -> list[str]:
    """The arm joints that reach a conservative limit (within 1 mrad) anywhere on the path."""
    lower = np.any(q <= Q_LOWER_CONSERVATIVE + 1e-3, axis=0)
    upper = np.any(q >= Q_UPPER_CONSERVATIVE - 1e-3, axis=0)
    return [name for name, hit in zip(RIGHT_ARM_JOINTS, lower | upper) if hit]


def line_contact(base: TipTrajectory, tool: float, push_direction, p_WB):
    """The steepest tilt of TILTS_DEG that the IK follows for `tool` (see the module
    docstring), checked on the trajectory for the nominal box start `p_WB` (the replays shifted
    by a run's box start are not checked again): (the IK's `ReachabilityReport` of it, tilt in
    degrees, every pose reached with no jump)."""
    best = None
    for deg in TILTS_DEG:
        try:
            report = filter_reachable(tilted(base, np.radians(deg), push_direction, p_WB), tool)
        except ValueError:  # no pose reachable
            continue
        step = float(np.abs(np.diff(report.joint_positions, axis=0)).max(initial=0.0))
        if report.reachable == report.poses and step <= MAX_JOINT_STEP:
            return report, deg, True
        if best is None or report.reachable > best[0]:
            best = (report.reachable, report, deg)
    if best is None:
        raise ValueError(f"no tilt of {TILTS_DEG} degrees is reachable with the {tool} m tool")
    return best[1], best[2], False


def main() -> None:
    ap = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--policy", type=Path, default=ROOT / POLICY)
    ap.add_argument("--episodes", type=int, default=100, help="recorded episodes")
    ap.add_argument("--runs", type=int, default=10, help="replay runs per tool and world")
    ap.add_argument("--seed", type=int, default=0, help="the first replay run's seed")
    ap.add_argument(
        "--tools", type=float, nargs="+", default=[*PAPER_TOOL_LENGTHS, 0.25, 0.3], help="m"
    )
    ap.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    try:  # bad input: one line naming the value, not a traceback
        check_int(args.episodes, 1, 10_000, "--episodes")
        check_int(args.runs, 1, 10_000, "--runs")
        check_seed(args.seed, "--seed", args.runs)
        for tool in args.tools:
            check_tool_length(tool, "--tools")
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
    rows = []
    for variant in args.variants:
        box_frame, tilt = VARIANTS[variant].box_frame, VARIANTS[variant].line_contact
        base = trajectory(recorded, period, variant, nominal_box)
        for tool in args.tools:
            if tilt:
                report, tilt_deg, tilt_reachable = line_contact(
                    base, tool, push_direction, nominal_box
                )
            else:
                report, tilt_deg, tilt_reachable = filter_reachable(base, tool), 0, True
            kept = report.kept
            runs = {"nominal": [], "reality": []}
            for i in range(args.runs):
                nominal, reality, believed, box_xy = worlds[tool, i]
                knows = RobotBelief(tool, (0.0, nominal.tool.grasp_offset_along))
                for world, scenario, belief, p_WBox_xy in (
                    ("nominal", nominal, knows, initial_box_pose(nominal).translation()[:2]),
                    ("reality", reality, believed, box_xy),
                ):
                    dxy = p_WBox_xy - nominal_box[:2]
                    run = run_open_loop(scenario, shifted(kept, dxy) if box_frame else kept, belief)
                    moved = run.box_path[-1] - run.box_path[0]
                    runs[world].append(
                        {
                            "success": bool(run.success),
                            "box_travel_m": float(run.box_travel),
                            "final_box_to_goal_m": float(run.final_box_to_goal),
                            "box_dx_m": float(moved[0]),  # across the push (+y)
                            "sim_error": bool(run.sim_error),
                        }
                    )
            row = {"variant": variant, "tool_length_m": tool, "poses": len(base)}
            row["poses_kept"] = len(kept)
            row["tilt_deg"], row["tilt_reachable"] = tilt_deg, tilt_reachable
            row["joints_at_limit"] = joints_at_limit(report.joint_positions)
            for world, rs in runs.items():
                row[world] = {
                    "at_goal": sum(r["success"] for r in rs),
                    "runs": len(rs),
                    "box_travel_mean_m": float(np.mean([r["box_travel_m"] for r in rs])),
                    "final_box_to_goal_mean_m": float(
                        np.mean([r["final_box_to_goal_m"] for r in rs])
                    ),
                    "box_across_mean_abs_m": float(np.mean([abs(r["box_dx_m"]) for r in rs])),
                    "per_run": rs,
                }
            rows.append(row)
            n, r = row["nominal"], row["reality"]
            print(
                f"{variant} {tool} m (tilt {tilt_deg}°, joints at a limit: "
                f"{', '.join(row['joints_at_limit']) or 'none'}): at the goal {n['at_goal']}/{n['runs']} nominal, "
                f"{r['at_goal']}/{r['runs']} reality; travel {n['box_travel_mean_m'] * 100:.1f}"
                f" / {r['box_travel_mean_m'] * 100:.1f} cm",
                flush=True,
            )
    atomic_write_json(
        args.out,
        {
            "command": f"python benchmarks/open_loop_variants.py --episodes {args.episodes} "
            f"--runs {args.runs} --seed {args.seed} --tools "
            + " ".join(f"{t:g}" for t in args.tools)
            + ("" if args.variants == list(VARIANTS) else " --variants " + " ".join(args.variants)),
            "policy": str(POLICY) if args.policy == ROOT / POLICY else str(args.policy),
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
            x["reality"]["box_travel_mean_m"]
            for x in rows
            if x["variant"] == row["variant"] and x["tool_length_m"] in PAPER_TOOL_LENGTHS
        ]
        differ = f"{(max(pair) - min(pair)) * 100:.2f}" if len(pair) == 2 else "—"
        nominal_travel = n["box_travel_mean_m"]
        ratio = f"{r['box_travel_mean_m'] / nominal_travel * 100:.0f} %" if nominal_travel else "—"
        label = row["variant"]
        if row["tilt_deg"]:
            label += f" ({row['tilt_deg']}°{'' if row['tilt_reachable'] else ', not reached'})"
        print(
            f"| {label} | {row['tool_length_m']:.3f} | {n['at_goal']} / {r['at_goal']} of "
            f"{r['runs']} | {n['box_travel_mean_m'] * 100:.1f} / {r['box_travel_mean_m'] * 100:.1f}"
            f" | {ratio} | "
            f"{r['final_box_to_goal_mean_m'] * 100:.1f} | {r['box_across_mean_abs_m'] * 100:.1f} | "
            f"{differ} |"
        )
    print(f"\nwrote {args.out} ({(time.perf_counter() - start) / 60:.1f} min)")


if __name__ == "__main__":
    main()
