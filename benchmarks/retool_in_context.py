"""Can the pull env keep one world for every hook? What Drake offers against the per-episode
rebuild, measured: a hook changed in a context (`SceneGraph.ChangeShape(context, …)` for its
collision pieces, `RigidBody.SetSpatialInertiaInBodyFrame`, `FixedOffsetFrame.
SetPoseInParentFrame` for its frames and the grasp) against a world built for that hook.

For each of `--pairs` pairs of hooks drawn as the env draws them (`tasks.pull.hook.draw_hook`):
the time of building the hook's world (plant, scene graph, diagram, context: the part of an
episode's rebuild that the context change would replace) and of the change; then both worlds,
started alike, driven by the same joint targets for `--steps` control periods, and the largest
difference of their states — with the other hook's world changed to this hook, with this
hook's own world changed to itself (every shape as it was), and, as a control, with only its
frames and inertia set again (no `ChangeShape`).

    python benchmarks/retool_in_context.py [--pairs 5] [--steps 100] [--out FILE]

Prints a Markdown table and writes it as JSON to a new runs/retool_in_context-<time>/ (or --out).
"""

import argparse
import platform
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

import drake_tooluse  # noqa: F401  (registers the envs)
from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.files import atomic_write_json
from drake_tooluse.limits import MAX_BENCHMARK_PERIODS, MAX_TOOL_PAIRS
from drake_tooluse.paths import SCENARIOS_DIR
from drake_tooluse.robot.model import (
    GRASP_FRAME,
    drake_shape,
    rigid_transform,
    tool_grasp_pose,
    tool_spatial_inertia,
)
from drake_tooluse.tasks.pull.env import with_hook
from drake_tooluse.tasks.pull.hook import draw_hook
from drake_tooluse.validation import check_int, check_seed
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import add_world, true_tool

OUTPUT = BenchmarkOutput(Path(__file__))
PERIOD = 0.04  # s: the control period


def home(hook) -> np.ndarray:
    """The pull env's home joint angles for `hook` (its IK on the hook's corner)."""
    env = gym.make("drake_tooluse/ToolPull-v1", hook=hook)
    try:
        return env.unwrapped.control.q0.copy()
    finally:
        env.close()


def build(scenario):
    """(diagram, world, context, seconds to build them) of `scenario`'s world alone, nothing
    drawn, its joint-target input exported."""
    start = time.perf_counter()
    builder = DiagramBuilder()
    world = add_world(builder, scenario, visuals=False)
    builder.ExportInput(world.plant.get_desired_state_input_port(world.baxter), "command")
    diagram = builder.Build()
    context = diagram.CreateDefaultContext()
    return diagram, world, context, time.perf_counter() - start


def retool(world, context, scenario, shapes: bool = True) -> float:
    """Sets `scenario`'s hook into the world's `context` (collision shapes where `shapes`, the
    inertia, the tool's frames, the grasp). Returns the seconds it took."""
    start = time.perf_counter()
    plant, scene_graph = world.plant, world.scene_graph
    plant_context = plant.GetMyMutableContextFromRoot(context)
    tool = true_tool(scenario)
    world.tool.SetSpatialInertiaInBodyFrame(plant_context, tool_spatial_inertia(tool))
    if shapes:
        sg_context = scene_graph.GetMyMutableContextFromRoot(context)
        inspector = scene_graph.model_inspector()
        ids = {
            inspector.GetName(g).split("::")[-1]: g
            for g in plant.GetCollisionGeometriesForBody(world.tool)
        }
        for piece in tool.collision_pieces():
            scene_graph.ChangeShape(
                sg_context,
                plant.get_source_id(),
                ids[piece.name],
                drake_shape(piece.shape),
                rigid_transform(piece.X_HP),
            )
    for name, X_HF in tool.frames().items():
        if plant.HasFrameNamed(name):
            plant.GetFrameByName(name).SetPoseInParentFrame(plant_context, rigid_transform(X_HF))
    t = scenario.tool  # the grasp, as `world.scene.set_randomized_state` sets it
    plant.GetFrameByName(GRASP_FRAME).SetPoseInParentFrame(
        plant_context, tool_grasp_pose(t.grasp_offset_across, t.grasp_offset_along)
    )
    return time.perf_counter() - start


def states(diagram, world, context, q0, steps: int) -> np.ndarray:
    """The plant's state after each of `steps` control periods, the arm started at q0 and
    driven toward q0 moved along a fixed sinusoid (the same targets for every world)."""
    plant_context = world.plant.GetMyMutableContextFromRoot(context)
    for joint, q in zip(world.arm_joints(), q0):
        joint.set_angle(plant_context, q)
    simulator = Simulator(diagram, context)
    port = diagram.get_input_port()
    out = []
    for k in range(steps):
        target = q0 + 0.15 * np.sin(0.1 * k + np.arange(7))
        port.FixValue(context, np.concatenate([target, np.zeros(7)]))
        simulator.AdvanceTo((k + 1) * PERIOD)
        out.append(world.plant.GetPositionsAndVelocities(plant_context))
    return np.array(out)


def pair(rng, steps: int) -> dict:
    base = load_scenario(SCENARIOS_DIR / "pull.yaml")
    hook, other = draw_hook(rng), draw_hook(rng)
    scenario, other_scenario = with_hook(base, hook), with_hook(base, other)
    q0 = home(hook)
    reference, world, context, build_s = build(scenario)
    truth = states(reference, world, context, q0, steps)
    rows = {"hook": hook, "other_hook": other, "build_ms": build_s * 1e3}
    for case, start, shapes in (
        ("other_hook_changed", other_scenario, True),
        ("own_hook_changed_to_itself", scenario, True),
        ("own_hook_frames_and_inertia_only", scenario, False),
    ):
        diagram, w, c, _ = build(start)
        seconds = retool(w, c, scenario, shapes)
        rows[f"{case}_retool_ms"] = seconds * 1e3
        rows[f"{case}_max_abs_diff"] = float(np.abs(states(diagram, w, c, q0, steps) - truth).max())
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--pairs", type=int, default=5, help="pairs of hooks drawn")
    ap.add_argument("--steps", type=int, default=100, help="control periods simulated")
    ap.add_argument("--seed", type=int, default=0, help="seed of the hooks' draws")
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    try:
        check_int(args.pairs, 1, MAX_TOOL_PAIRS, "--pairs")
        check_int(args.steps, 1, MAX_BENCHMARK_PERIODS, "--steps")
        check_seed(args.seed, "--seed")
    except ValueError as e:
        ap.error(str(e))
    out = OUTPUT.path(args)
    rng = np.random.default_rng(args.seed)
    rows = [pair(rng, args.steps) for _ in range(args.pairs)]
    print(
        "| hook (handle m, hook m, angle °) | build ms | change ms | max |Δx|: other hook "
        "changed | own hook changed to itself | frames and inertia only |"
    )
    print("| --- | --- | --- | --- | --- | --- |")
    for r in rows:
        hook = ", ".join(f"{v:.3g}" for v in r["hook"])
        print(
            f"| {hook} | {r['build_ms']:.1f} | {r['other_hook_changed_retool_ms']:.2f} | "
            f"{r['other_hook_changed_max_abs_diff']:.2g} | "
            f"{r['own_hook_changed_to_itself_max_abs_diff']:.2g} | "
            f"{r['own_hook_frames_and_inertia_only_max_abs_diff']:.2g} |"
        )
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/retool_in_context.py --pairs {args.pairs} "
            f"--steps {args.steps} --seed {args.seed}",
            "machine": platform.platform(),
            "rows": rows,
        },
    )
    print(f"\nwrote {out}")


if __name__ == "__main__":
    sys.exit(run_script(main))
