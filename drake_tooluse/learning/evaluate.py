"""Evaluating a policy, and the one episode loop every policy rollout runs."""

from __future__ import annotations

import sys
from dataclasses import dataclass, field

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from drake_tooluse.learning.policy_dir import check_policy_env, check_policy_matches, load_policy
from drake_tooluse.validation import check_int, check_seed


@dataclass
class EvalResult:
    episodes: int
    seed: int
    final_box_to_goal_mean_m: float
    final_box_to_goal_median_m: float
    final_box_to_goal_std_m: float
    success_rate: float
    box_travel_mean_m: float
    episode_length_mean: float
    tool_touched_rate: float
    gripper_touched_rate: float
    # Episodes the simulation failed in (truncated with finite values; counted as failures).
    sim_errors: int = 0
    # Each episode ran on past its success to the step limit (see `run_episode`).
    to_time_limit: bool = False
    per_episode: list = field(default_factory=list)


def make_policy_env(
    policy_dir,
    env_id: str | None = None,
    env_kwargs: dict | None = None,
    trust_pickle: bool = False,
):
    """Loads a policy directory and makes the env it acts in: its own env id and kwargs
    unless `env_id` / `env_kwargs` override them (`check_policy_env`: the id registered, the
    kwargs valid, the spaces the policy's). Returns (policy, env)."""
    policy = load_policy(policy_dir, trust_pickle=trust_pickle)
    env_id, kwargs = check_policy_env(policy, env_id, env_kwargs)
    env = gym.make(env_id, **kwargs)
    check_policy_matches(policy, env)
    return policy, env


def run_episode(env, policy, seed: int, on_step=None, to_time_limit: bool = False):
    """One deterministic episode of `policy` from `env.reset(seed=seed)` until it terminates
    (the box at the goal) or is truncated — with `to_time_limit`, on past the success until it
    is truncated (the step limit, or a simulation failure), as a protocol without an early end
    measures where the box ends. `on_step(step, info)` is called after the reset (step 0) and
    after each step. Returns the last info and the number of steps."""
    obs, info = env.reset(seed=seed)
    if on_step is not None:
        on_step(0, info)
    steps = 0
    while True:
        obs, _, terminated, truncated, info = env.step(policy.act(obs))
        steps += 1
        if on_step is not None:
            on_step(steps, info)
        if truncated or (terminated and not to_time_limit):
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
    `to_time_limit` each episode runs on past its success to the step limit and is judged
    where it ends (`run_episode`). With `progress`, a bar of the episodes (and the success so
    far) on stderr, when stderr is a terminal."""
    check_int(episodes, 1, 1_000_000, "episodes")
    check_seed(seed, "seed", episodes)
    policy, env = make_policy_env(policy_dir, env_id, env_kwargs, trust_pickle)
    rows = []
    bar = tqdm(
        total=episodes,
        desc="episodes",
        unit="ep",
        file=sys.stderr,
        disable=not progress or not sys.stderr.isatty(),  # no \r fragments in a log file
        leave=False,
    )
    try:
        for ep in range(episodes):
            info, steps = run_episode(env, policy, seed + ep, to_time_limit=to_time_limit)
            rows.append(
                {
                    "seed": seed + ep,
                    "final_box_to_goal_m": info["box_to_goal"],
                    "success": bool(info["is_success"]) and not info["sim_error"],
                    "box_travel_m": info["box_travel"],
                    "length": steps,
                    "tool_touched": info["tool_touched_box_in_episode"],
                    "gripper_touched": info["gripper_touched_box_in_episode"],
                    "sim_error": bool(info["sim_error"]),
                }
            )
            bar.update(1)
            bar.set_postfix(success=f"{np.mean([r['success'] for r in rows]) * 100:.0f}%")
    finally:
        bar.close()
        env.close()
    d = np.array([r["final_box_to_goal_m"] for r in rows])
    return EvalResult(
        episodes=episodes,
        seed=seed,
        final_box_to_goal_mean_m=float(d.mean()),
        final_box_to_goal_median_m=float(np.median(d)),
        final_box_to_goal_std_m=float(d.std()),
        success_rate=float(np.mean([r["success"] for r in rows])),
        box_travel_mean_m=float(np.mean([r["box_travel_m"] for r in rows])),
        episode_length_mean=float(np.mean([r["length"] for r in rows])),
        tool_touched_rate=float(np.mean([r["tool_touched"] for r in rows])),
        gripper_touched_rate=float(np.mean([r["gripper_touched"] for r in rows])),
        sim_errors=sum(r["sim_error"] for r in rows),
        to_time_limit=bool(to_time_limit),
        per_episode=rows,
    )
