"""Is the fast env still the same task? Two checks behind the env's speed choices.

A. The first-order IK mode (`ik_mode="differential"`, Drake's differential IK integrator) against
   the full tool-tip IK: from the same measured joints, each is given the same next tool-tip
   target (a random walk of the policy's action sizes: up to 2 cm a step, the orientation held
   or turned up to 0.05 rad a step), and the commanded joints' tip pose is compared with the
   target.
B. The plant time step: the scripted push (randomized starts) at 5, 10 and 20 ms, full IK.

    python benchmarks/env_fidelity.py [--targets 2000] [--episodes 20] [--out FILE]

Prints Markdown tables and writes docs/results/env_fidelity.json (or --out).
"""

import argparse
import copy
import dataclasses as dc
import logging
import platform
from pathlib import Path

import gymnasium as gym
import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RollPitchYaw, RotationMatrix
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

import drake_tooluse  # noqa: F401
from drake_tooluse.diagrams.control import add_differential_ik, home_configuration
from drake_tooluse.envs.scripted import ScriptedPush
from drake_tooluse.files import atomic_write_json
from drake_tooluse.robot.ik import ToolTipIK, rotation_angle_between
from drake_tooluse.systems.tip_target import MAX_TRANSLATION_STEP, Workspace
from drake_tooluse.world.scenario import Scenario

OUT = Path(__file__).resolve().parent.parent / "docs" / "results" / "env_fidelity.json"


def ik_modes(n: int, rotation_step: float, seed: int = 0) -> dict:
    scenario = Scenario()
    full = ToolTipIK(scenario.tool.length)
    q0 = home_configuration(scenario, full)
    model = ToolTipIK(scenario.tool.length, library_size=1)
    builder = DiagramBuilder()
    diff = add_differential_ik(builder, model, q0, scenario.control.control_period)
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = diff.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    diff.GetInputPort("use_robot_state").FixValue(context, AbstractValue.Make(True))
    workspace = Workspace.above_table(scenario.table.top_z)
    rng = np.random.default_rng(seed)
    q = q0.copy()
    X = full.fk(q)
    rows = {"full": [], "differential": []}
    for k in range(n):
        p = np.clip(
            X.translation() + rng.uniform(-1, 1, 3) * MAX_TRANSLATION_STEP,
            workspace.lower,
            workspace.upper,
        )
        R = RotationMatrix(RollPitchYaw(rng.uniform(-1, 1, 3) * rotation_step)) @ X.rotation()
        target = RigidTransform(R, p)
        result = full.solve(target, q)
        diff.GetInputPort("robot_state").FixValue(context, np.concatenate([q, np.zeros(7)]))
        diff.GetInputPort("X_AE_desired").FixValue(context, AbstractValue.Make(target))
        simulator.AdvanceTo((k + 1) * scenario.control.control_period)
        q_diff = diff.GetOutputPort("joint_positions").Eval(context)
        if not result.success:  # an unreachable target: not a tracking comparison
            continue
        for name, q_cmd in (("full", result.q), ("differential", q_diff)):
            X_cmd = full.fk(q_cmd)
            rows[name].append(
                (
                    np.linalg.norm(X_cmd.translation() - p),
                    rotation_angle_between(X_cmd.rotation(), R),
                )
            )
        q, X = result.q, target
    out = {"targets": n, "compared": len(rows["full"])}
    for name, r in rows.items():
        e = np.array(r)
        out[name] = {
            "position_median_mm": float(np.median(e[:, 0]) * 1e3),
            "position_p99_mm": float(np.percentile(e[:, 0], 99) * 1e3),
            "position_max_mm": float(e[:, 0].max() * 1e3),
            "orientation_max_rad": float(e[:, 1].max()),
        }
    return out


def time_steps(episodes: int) -> list:
    out = []
    for dt in (0.005, 0.01, 0.02):
        base = Scenario()
        plant = copy.copy(base.plant)  # Drake's MultibodyPlantConfig: not a dataclass
        plant.time_step = dt
        scenario = dc.replace(base, plant=plant)
        env = gym.make(
            "drake_tooluse/ToolPush-v0", action_mode="position", scenario=scenario, randomize=True
        )
        policy = ScriptedPush(scenario.table.top_z)
        rows = []
        for ep in range(episodes):
            obs, _ = env.reset(seed=ep)
            policy.reset()
            for steps in range(1, 101):  # noqa: B007  (read after the loop)
                obs, _, terminated, truncated, info = env.step(policy(obs))
                if terminated or truncated:
                    break
            rows.append((terminated, steps, info["box_to_goal"], info["box_travel"]))
        r = np.array(rows, float)
        out.append(
            {
                "time_step_s": dt,
                "success_rate": float(r[:, 0].mean()),
                "steps_mean": float(r[:, 1].mean()),
                "final_box_to_goal_mean_m": float(r[:, 2].mean()),
                "box_travel_mean_m": float(r[:, 3].mean()),
            }
        )
    return out


def main() -> None:
    # Drake logs each switch of the differential IK into and out of "no solution"; the table
    # counts what matters.
    logging.getLogger("drake").setLevel(logging.ERROR)
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--targets", type=int, default=2000)
    ap.add_argument("--episodes", type=int, default=20)
    ap.add_argument("--out", type=Path, default=OUT)
    args = ap.parse_args()
    walks = {"position walk (orientation held)": 0.0, "pose walk (±0.05 rad a step)": 0.05}
    modes = {walk: ik_modes(args.targets, step) for walk, step in walks.items()}
    print(
        "A. Commanded tip pose vs target, one control step from the same joints (targets "
        "the full IK reaches)\n"
    )
    print(
        "| target walk | compared | IK mode | position median / p99 / max (mm) | "
        "orientation max (rad) |"
    )
    print("| --- | --- | --- | --- | --- |")
    for walk, m in modes.items():
        for name in ("full", "differential"):
            r = m[name]
            print(
                f"| {walk} | {m['compared']} | {name} | {r['position_median_mm']:.4f} / "
                f"{r['position_p99_mm']:.4f} / {r['position_max_mm']:.4f} | "
                f"{r['orientation_max_rad']:.2e} |"
            )
    steps = time_steps(args.episodes)
    print(f"\nB. Scripted push, randomized starts, {args.episodes} episodes per plant step\n")
    print("| plant step (ms) | success | steps (mean) | final box–goal (cm) | box travel (cm) |")
    print("| --- | --- | --- | --- | --- |")
    for r in steps:
        print(
            f"| {r['time_step_s'] * 1e3:g} | {r['success_rate'] * 100:.0f} % | "
            f"{r['steps_mean']:.1f} | {r['final_box_to_goal_mean_m'] * 100:.2f} | "
            f"{r['box_travel_mean_m'] * 100:.2f} |"
        )
    atomic_write_json(
        args.out,
        {
            "command": f"python benchmarks/env_fidelity.py --targets "
            f"{args.targets} --episodes {args.episodes}",
            "machine": platform.platform(),
            "ik_modes": modes,
            "time_steps": steps,
        },
    )
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
