"""Where does a distilled push policy lose to its expert? The distillation's expert
(`experiments.distill.Expert`: the teacher's action and, for the 7-d action, the quaternion
change back to the initial orientation) beside the student, in the paper's task (Env1, the
0.175 m tool, each episode to its 100-step limit) at fixed actuation delays.

    python benchmarks/distill_gap.py --student DIR [--teacher DIR] [--episodes 40]
        [--seed 2000] [--delays 0 0.02 0.04]

The teacher defaults to the one the student was distilled from (the `--teacher` of its
command). Each row: the success rate, the mean final box–goal distance, and of the failed
episodes how many had reached the goal earlier (near misses: pushed on past it, or the tip
left the box; the paper's criterion is box–goal plus tip–box ≤ 5 cm) with their mean
box–goal and tip–box distances at the end. Prints a Markdown table.
"""

import argparse
import shlex
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.distill import Expert, check_teacher
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.limits import MAX_EPISODES
from drake_tooluse.validation import check_int, check_seed
from drake_tooluse.world.scenario import MAX_ACTUATION_DELAY


def teacher_of(student, student_dir) -> Path:
    """The `--teacher` of the command that distilled `student` (in `student_dir`). A relative
    path is from where distill ran: the working directory, or else the nearest directory
    above the student's that holds it (the checkout, for a shipped student)."""
    words = shlex.split(student.meta.command or "")
    if "--teacher" not in words[:-1]:
        raise ValueError(
            f"the student's command {student.meta.command!r} names no --teacher; give --teacher"
        )
    teacher = Path(words[words.index("--teacher") + 1])
    if teacher.is_absolute() or teacher.exists():
        return teacher
    for parent in Path(student_dir).resolve().parents:
        if (parent / teacher).exists():
            return parent / teacher
    return teacher


def paper_task(student, delay: float) -> dict:
    """The student's env kwargs for the paper's task (the 17.5 cm tool) at `delay` (s): the
    delay range holds that one delay (a whole number of plant steps)."""
    return {
        **student.meta.env_kwargs,
        "tool_length_range": None,
        "actuation_delay_range": None if delay == 0 else [delay, delay + 1e-3],
    }


def rollouts(act, env_kwargs: dict, env_id: str, episodes: int, seed: int) -> dict:
    """`act(env, observation)` over `episodes` episodes (seeds seed, seed+1, …)."""
    env = gym.make(env_id, **env_kwargs)
    ends = []
    try:
        for episode in range(episodes):
            observation, _ = env.reset(seed=seed + episode)
            truncated, reached = False, False
            while not truncated:
                action = act(env.unwrapped, observation)
                observation, _, _, truncated, info = env.step(np.clip(action, -1, 1))
                reached |= info["is_success"]
            ends.append(
                (info["is_success"], reached, info["object_to_goal"], info["tip_to_object"])
            )
    finally:
        env.close()
    success = np.array([e[0] for e in ends])
    misses = [e for e in ends if not e[0] and e[1]]
    return {
        "success": success.mean(),
        "object_to_goal": np.mean([e[2] for e in ends]),
        "failures": int((~success).sum()),
        "near_misses": len(misses),
        "miss_object_to_goal": np.mean([e[2] for e in misses]) if misses else float("nan"),
        "miss_tip_to_object": np.mean([e[3] for e in misses]) if misses else float("nan"),
    }


def cm(metres: float) -> str:
    """Metres in cm, or "–" where there is nothing to average (no near misses)."""
    return "–" if np.isnan(metres) else f"{metres * 100:.2f}"


def check_args(args) -> None:
    check_int(args.episodes, 1, MAX_EPISODES, "--episodes")
    check_seed(args.seed, "--seed", args.episodes)
    for delay in args.delays:
        if not 0 <= delay <= MAX_ACTUATION_DELAY:
            raise ValueError(f"--delays {delay} is outside [0, {MAX_ACTUATION_DELAY}] s")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--student", type=Path, required=True, help="the distilled policy directory")
    ap.add_argument("--teacher", type=Path, help="default: the one it was distilled from")
    ap.add_argument("--episodes", type=int, default=40, help="episodes per row")
    ap.add_argument("--seed", type=int, default=2000, help="seed of the first episode")
    ap.add_argument("--delays", nargs="+", type=float, default=[0.0, 0.02, 0.04], help="s")
    args = ap.parse_args()
    try:
        check_args(args)
        student = load_policy(args.student)
        teacher_dir = args.teacher or teacher_of(student, args.student)
        teacher = load_policy(teacher_dir)
        check_teacher(teacher)
    except (ValueError, FileNotFoundError) as e:
        ap.error(str(e))
    mode = student.meta.env_kwargs.get("action_mode", "position_quaternion")
    actors = {
        "expert": Expert(teacher, mode),
        "student": lambda env, observation: student.act(observation),
    }
    print(
        "| delay (ms) | who | success | box–goal (cm) | failures | near misses | their box–goal "
        "(cm) | their tip–box (cm) | wall (s) |"
    )
    print("|---" * 9 + "|")
    for delay in args.delays:
        for who, act in actors.items():
            start = time.perf_counter()
            kwargs = paper_task(student, delay)
            r = rollouts(act, kwargs, student.meta.env_id, args.episodes, args.seed)
            print(
                f"| {delay * 1000:g} | {who} | {r['success'] * 100:.0f} % | "
                f"{r['object_to_goal'] * 100:.2f} | {r['failures']} | {r['near_misses']} | "
                f"{cm(r['miss_object_to_goal'])} | {cm(r['miss_tip_to_object'])} | "
                f"{time.perf_counter() - start:.0f} |",
                flush=True,
            )
    print(
        f"the paper's task (0.175 m tool), {args.episodes} episodes from seed {args.seed} per "
        f"row; student {args.student}, expert: {teacher_dir} with "
        f"the {mode} label"
    )
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
