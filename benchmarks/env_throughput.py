"""Env throughput: random-action steps per second on one core, ours beside Gymnasium-Robotics'
FetchPushDense-v4 (MuJoCo) measured in the same run (interleaved rounds: the median round, and
the median of the per-round ratios), and where a step's time goes.

    pip install -e ".[bench]"        # mujoco < 3.4 + gymnasium-robotics 1.4.2 (optional)
    python benchmarks/env_throughput.py [--steps 4000] [--out FILE | --update-docs]

Prints a Markdown table and writes it as JSON to a new
runs/env_throughput-<time>/env_throughput.json (or --out; `--update-docs`:
docs/results/env_throughput.json, which docs/BENCHMARKS.md quotes).
"""

import argparse
import os
import platform
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import gymnasium as gym  # noqa: E402
import numpy as np  # noqa: E402

import drake_tooluse  # noqa: E402,F401
from drake_tooluse.experiments.runs import BenchmarkOutput  # noqa: E402
from drake_tooluse.files import atomic_write_json  # noqa: E402

FETCH = "FetchPushDense-v4 (MuJoCo)"
OUTPUT = BenchmarkOutput(Path(__file__))


def run_random(env, steps: int, seed: int = 0) -> float:
    """Seconds per step over `steps` random-action steps, resets included."""
    env.reset(seed=seed)
    env.action_space.seed(seed)
    start = time.perf_counter()
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            env.reset()
    return (time.perf_counter() - start) / steps


def interleaved(envs: dict, steps: int, rounds: int) -> dict:
    """Seconds per step of each env in each of `rounds` rounds, each env taking
    `steps // rounds` steps in turn (so a slow spell of the machine falls on all of them)."""
    times = {name: [] for name in envs}
    for r in range(rounds):
        for name, env in envs.items():
            times[name].append(run_random(env, max(steps // rounds, 1), seed=r))
    return {name: np.array(t) for name, t in times.items()}


class _Timer:
    """Wraps a bound method and adds up the time spent in it."""

    def __init__(self, obj, name):
        self.total, self._f = 0.0, getattr(obj, name)
        setattr(obj, name, self)

    def __call__(self, *args, **kwargs):
        start = time.perf_counter()
        try:
            return self._f(*args, **kwargs)
        finally:
            self.total += time.perf_counter() - start


def breakdown(steps: int) -> dict:
    """Per-step time of each part, in ms, with the timers on: the tip target, the IK (its
    solve), the observation, the metrics (reward, info); the world alone on the same joint
    commands (`world_on_commands_ms`); and the rest: Drake's framework around the Python
    systems (events, ports), the IK system's update beyond the solve, the env's step and
    checks, resets, the random actions. Of the IK's solve, the part in its SNOPT fallback
    (where the fast path finds nothing: a target no start reaches) is given apart, with the
    share of steps that reach it."""
    env = gym.make("drake_tooluse/ToolPush-v1")
    u = env.unwrapped
    ik = u.ik_system.ik
    snopt, found = ik.solve_with_snopt, []

    def counted(*args, **kwargs):  # the fallback's answers: how often it finds one
        result = snopt(*args, **kwargs)
        found.append(result.success)
        return result

    ik.solve_with_snopt = counted
    fallback = _Timer(ik, "solve_with_snopt")
    timers = {
        "tip target": _Timer(u.target_system, "_target"),
        "IK (solve)": _Timer(u.ik_system.ik, "solve"),
        "observation": _Timer(u.observation_system, "finite_observation"),
        "metrics (reward, info)": _Timer(u, "_read_metrics"),
    }
    total = run_random(env, steps)
    parts = {}
    for name, t in timers.items():
        parts[name] = t.total / steps * 1e3
        if name == "IK (solve)":  # its fallback's part beside it
            share = len(found) / steps * 100
            what = f"{share:.1f} % of steps, {sum(found)} of {len(found)} found an answer"
            parts[f"of which the SNOPT fallback ({what})"] = fallback.total / steps * 1e3
    parts["world alone, same joint commands"] = world_on_commands_ms(joint_commands(steps))
    parts["framework, env step, rest"] = total * 1e3 - sum(
        v for k, v in parts.items() if not k.startswith("of which")
    )
    return parts


def joint_commands(steps: int) -> list:
    """The IK's joint command [q*, 0] after each step of `run_random(env, steps)` (the same
    seed, so the same steps), one list per episode."""
    env = gym.make("drake_tooluse/ToolPush-v1")
    u = env.unwrapped
    env.reset(seed=0)
    env.action_space.seed(0)
    port = u.ik_system.GetOutputPort("desired_state")
    episodes = [[]]
    for _ in range(steps):
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        ik_context = u.ik_system.GetMyContextFromRoot(u.simulator.get_context())
        episodes[-1].append(port.Eval(ik_context).copy())
        if terminated or truncated:
            env.reset()
            episodes.append([])
    env.close()
    return [e for e in episodes if e]


def world_on_commands_ms(episodes: list) -> float:
    """One 40 ms control period of the world alone (its plant and scene graph, no Python
    system), each episode started as the env starts it and driven by the env's joint
    commands, in ms. (The command reaches the plant one 20 ms plant step sooner than the
    IK's update gives it in the env: the motion is the env's to within that.)"""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder

    from drake_tooluse.builders.control import add_world_at_home
    from drake_tooluse.world.scenario import Scenario
    from drake_tooluse.world.scene import set_randomized_state

    s = Scenario()
    builder = DiagramBuilder()
    world, _, _ = add_world_at_home(builder, s)
    builder.ExportInput(world.plant.get_desired_state_input_port(world.baxter), "command")
    diagram = builder.Build()
    simulator = Simulator(diagram)
    context = simulator.get_mutable_context()
    period, total, steps = s.control.control_period, 0.0, 0
    for commands in episodes:
        context.SetTime(0.0)
        diagram.SetDefaultContext(context)
        set_randomized_state(world, context, s)
        fixed = diagram.get_input_port().FixValue(context, commands[0])
        command = fixed.GetMutableData().get_mutable_value()
        simulator.Initialize()
        start = time.perf_counter()
        for q in commands:
            fixed.GetMutableData()
            command.SetFromVector(q)
            simulator.AdvanceTo(context.get_time() + period)
        total += time.perf_counter() - start
        steps += len(commands)
    return total / steps * 1e3


def plant_only_ms(steps: int = 500) -> float:
    """One 40 ms control period of the world alone (constant joint targets), in ms."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import ConstantVectorSource

    from drake_tooluse.builders.control import add_world_at_home
    from drake_tooluse.world.scenario import Scenario

    s = Scenario()
    builder = DiagramBuilder()
    world, _, q0 = add_world_at_home(builder, s)
    source = builder.AddSystem(ConstantVectorSource(np.concatenate([q0, np.zeros(7)])))
    builder.Connect(
        source.get_output_port(), world.plant.get_desired_state_input_port(world.baxter)
    )
    simulator = Simulator(builder.Build())
    simulator.Initialize()
    period = s.control.control_period
    start = time.perf_counter()
    for i in range(steps):
        simulator.AdvanceTo((i + 1) * period)
    return (time.perf_counter() - start) / steps * 1e3


def fetch_push_env():
    try:
        import gymnasium_robotics
    except ImportError:
        return None
    gym.register_envs(gymnasium_robotics)
    return gym.make("FetchPushDense-v4")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps", type=int, default=4000, help="random-action steps per env")
    ap.add_argument("--rounds", type=int, default=8, help="interleaved rounds (median taken)")
    ap.add_argument("--core", type=int, default=1, help="the one CPU core to run on")
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    out = OUTPUT.path(args)
    os.sched_setaffinity(0, {args.core})  # one core, as FetchPush runs
    envs = {}
    fetch_env = fetch_push_env()
    if fetch_env is not None:
        envs[FETCH] = fetch_env
    for action_mode in ("position_quaternion", "position"):
        envs[f"ToolPush-v1 action_mode={action_mode}"] = gym.make(
            "drake_tooluse/ToolPush-v1", action_mode=action_mode
        )
    # The pull task: a hook drawn each episode, so each reset builds a new world (counted).
    envs["ToolPull-v1"] = gym.make("drake_tooluse/ToolPull-v1")
    for env in envs.values():  # warm up: compiled kernels, caches
        run_random(env, 50)
    rounds = interleaved(envs, args.steps, args.rounds)
    fetch_rounds = rounds.get(FETCH)
    # Two ratios: of the median rounds, and the median of the per-round ratios (each round's
    # envs ran back to back, so the pair shares the machine's speed of that moment).
    print("| env | steps/s | ms/step | ratio of medians | median per-round ratio |")
    print("| --- | --- | --- | --- | --- |")
    results = []
    for name, t in rounds.items():
        sec = float(np.median(t))
        ours = fetch_rounds is not None and name != FETCH
        ratio = float(np.median(fetch_rounds)) / sec if ours else None
        paired = float(np.median(fetch_rounds / t)) if ours else None
        shown = [f"{x:.2f}" if x is not None else "—" for x in (ratio, paired)]
        print(f"| {name} | {1 / sec:.0f} | {sec * 1e3:.3f} | {shown[0]} | {shown[1]} |")
        results.append(
            {
                "env": name,
                "steps_per_s": 1 / sec,
                "ms_per_step": sec * 1e3,
                "ratio_to_fetchpush": ratio,
                "median_round_ratio_to_fetchpush": paired,
                "round_ms_per_step": [x * 1e3 for x in t],
            }
        )
    if fetch_rounds is None:
        print("(FetchPushDense-v4 not installed: pip install -e '.[bench]' to compare)")
    plant = plant_only_ms()
    parts = breakdown(max(args.steps // 2, 200))
    print(
        f"\nWhere a step's time goes (ms per step, action_mode=position_quaternion, timers on; "
        f"the world alone, constant joint targets: {plant:.3f} ms per 40 ms control period):\n"
    )
    print("| part | ms per step |")
    print("| --- | --- |")
    for k, v in parts.items():
        print(f"| {k} | {v:.3f} |")
    atomic_write_json(
        out,
        {
            "command": f"python benchmarks/env_throughput.py --steps {args.steps} "
            f"--rounds {args.rounds}",
            "machine": platform.platform(),
            "results": results,
            "plant_only_ms_per_control_period": plant,
            "breakdown_ms": parts,
        },
    )
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
