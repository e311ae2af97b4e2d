"""`train`, `evaluate`, `convert-policy`, `distill` and `sweep`: stable-baselines3 through the Gymnasium envs."""

from __future__ import annotations

import dataclasses
import shlex
import sys
from pathlib import Path

from drake_tooluse.cli.common import (
    EXIT_NOT_REACHED,
    EXIT_OK,
    UsageError,
    add_meshcat_arg,
    add_trust_pickle_arg,
    choice_arg,
    count_arg,
    env_arg,
    open_meshcat,
    output_dir_arg,
    parse_json_arg,
    policy_dir_arg,
    policy_env_id,
    seed_arg,
    serves_arg,
    serving_policy_arg,
    tool_length_arg,
)
from drake_tooluse.learning.algorithms import ALGOS
from drake_tooluse.learning.figures import format_figures
from drake_tooluse.learning.task_envs import task_env_ids
from drake_tooluse.tasks.contract import env_class
from drake_tooluse.validation import check_in_range


def in_cli_words(error: FileExistsError, out, what: str) -> FileExistsError:
    """The library's refusal of an --out that already holds a `what` (a run, a sweep) in the
    command line's words: the library's name its arguments (resume=True), these the flags."""
    if f"already holds a {what};" not in str(error):
        return error
    return FileExistsError(
        f"--out {str(out)!r} already holds a {what}; continue it with --resume {str(out)!r}, "
        "or give a new --out"
    )


def cmd_train(args) -> dict:
    # The cheap checks first: an argument error comes before the library loads.
    if args.resume is not None:
        out_dir = args.resume
        if args.out is not None and args.out != args.resume:
            raise UsageError("give --resume DIR alone (it is the run directory), not with --out")
        output_dir_arg(out_dir, "--resume", must_be_new=False)
    elif args.out is None:
        raise UsageError("give --out DIR for a new run, or --resume DIR to continue one")
    else:
        out_dir = output_dir_arg(args.out, "--out", must_be_new=False)
    if args.algo is not None:
        choice_arg(args.algo, ALGOS, "--algo", "algorithm")
    if args.env is not None:
        env_arg(args.env, "--env")
    saved = saved_timesteps(out_dir) if args.resume is not None else None
    timesteps = args.timesteps if args.timesteps is not None else saved or DEFAULT_TIMESTEPS
    count_arg(timesteps, "--timesteps")
    if args.seed is not None:
        seed_arg(args.seed)
    if args.n_envs is not None:
        count_arg(args.n_envs, "--n-envs")
    if args.init_from is not None:
        policy_dir_arg(args.init_from, "--init-from")
    overrides = parse_json_arg(args.hyperparams, "--hyperparams")
    overrides = _with_run_flags(args, overrides)
    env_kwargs = train_env_kwargs(args)
    import torch

    from drake_tooluse.learning.config import RUN_CONFIG, read_run_config, resolve_config
    from drake_tooluse.learning.train import train

    # A resume takes the run's own settings; flags given with it must match them (`train`
    # refuses, naming what differs), and the env, algorithm and seed not given are the run's.
    own = read_run_config(Path(out_dir) / RUN_CONFIG)[0] if saved is not None else None
    if own is not None and not _settings_given(args):
        config = dataclasses.replace(own, timesteps=timesteps)
    else:
        config = resolve_config(
            args.env or (own.env_id if own else DEFAULT_ENV),
            args.algo or (own.algo if own else DEFAULT_ALGO),
            timesteps,
            # Not given with --resume: the run's own (not the YAML's default).
            args.n_envs if args.n_envs is not None or own is None else own.n_envs,
            args.seed if args.seed is not None else (own.seed if own else 0),
            init_from=str(args.init_from) if args.init_from else None,
            # With --resume, what is not given is the run's own (its hyperparameters, not the
            # YAML's): the flags given must match the run, the rest is taken from it.
            overrides=overrides if own is None else {**own.hyperparams, **(overrides or {})},
            env_kwargs=env_kwargs,
        )
    # One torch thread: the env processes are the parallelism (2 cores here).
    torch.set_num_threads(1)
    command = "drake-tooluse " + shlex.join(sys.argv[1:]) if sys.argv else ""
    new_dir = not Path(out_dir).exists()
    try:
        summary = train(
            config,
            out_dir,
            resume=args.resume is not None,
            progress_bar=not args.no_progress and sys.stderr.isatty(),
            command=command,
            trust_pickle=args.trust_pickle,
        )
    except FileExistsError as e:
        if args.resume is not None:
            raise
        raise in_cli_words(e, out_dir, "run") from None
    except KeyboardInterrupt:
        if not (Path(out_dir) / "checkpoints" / "latest.json").is_file():
            raise  # no checkpoint yet: nothing to go on from
        raise KeyboardInterrupt(
            f"the run so far is saved in {str(out_dir)!r} (its last checkpoint); go on with "
            f"`drake-tooluse train --resume {shlex.quote(str(out_dir))}`"
        ) from None
    except Exception:
        if new_dir:  # a run refused before it began leaves no directory (its lock only)
            _remove_if_only_lock(Path(out_dir))
        raise
    if saved is not None and timesteps != saved:
        summary["budget_changed_from"] = saved
    return summary


DEFAULT_TIMESTEPS = 1_250_000
DEFAULT_ENV = "drake_tooluse/ToolPush-v1"
DEFAULT_ALGO = "ppo"
# rl-zoo's names for the run's evaluation and checkpoint settings: the hyperparameter each sets.
RUN_FLAGS = {
    "eval_freq": "eval_freq",
    "save_freq": "checkpoint_freq",
    "n_eval_episodes": "eval_episodes",
}


# The flags that set a run's configuration: a resume given none of them takes the run's own.
SETTINGS_FLAGS = (
    "env",
    "algo",
    "seed",
    "n_envs",
    "env_kwargs",
    "tool_length",
    "scenario",
    "init_from",
    "hyperparams",
    *RUN_FLAGS,
)


def _with_run_flags(args, overrides: dict | None) -> dict | None:
    """`--hyperparams` with `--eval-freq`, `--save-freq` and `--n-eval-episodes` put in (each
    checked here; one also set in `--hyperparams` is refused)."""
    given = {f: getattr(args, f) for f in RUN_FLAGS if getattr(args, f, None) is not None}
    if not given:
        return overrides
    overrides = dict(overrides or {})
    for flag, value in given.items():
        option = "--" + flag.replace("_", "-")
        count_arg(value, option)
        key = RUN_FLAGS[flag]
        if key in overrides:
            raise UsageError(f"give {option} or {key} in --hyperparams, not both")
        overrides[key] = value
    return overrides


def _settings_given(args) -> bool:
    return any(getattr(args, name) is not None for name in SETTINGS_FLAGS)


def saved_timesteps(out_dir) -> int | None:
    """The budget of the run in `out_dir` (its config.json), or None where there is none (the
    library then says there is nothing to resume)."""
    from drake_tooluse.files import read_json

    path = Path(out_dir) / "config.json"
    if not path.is_file():
        return None
    timesteps = (read_json(path, "run configuration") or {}).get("timesteps")
    return count_arg(timesteps, "--timesteps", f"{str(path)!r}: timesteps")


def _remove_if_only_lock(out_dir: Path) -> None:
    if out_dir.is_dir() and [p.name for p in out_dir.iterdir()] == [".lock"]:
        (out_dir / ".lock").unlink()
        out_dir.rmdir()


def train_env_kwargs(args) -> dict:
    """The env's keyword arguments the train command was given: --env-kwargs, with
    --tool-length and --scenario on top (each the env kwarg of that name)."""
    env_kwargs = dict(parse_json_arg(args.env_kwargs, "--env-kwargs") or {})
    if args.tool_length is not None:
        env_kwargs["tool_length"] = tool_length_arg(args.tool_length)
    if args.scenario is not None:
        from drake_tooluse.world.scenario import load_scenario

        load_scenario(args.scenario)  # a missing or bad file is refused before the run starts
        env_kwargs["scenario"] = str(args.scenario.resolve())
    return env_kwargs


def format_train(out: dict) -> str:
    rate = "" if out.get("steps_per_s") is None else f" ({out['steps_per_s']:.0f} steps/s)"
    resumed = f", {out['sessions']} sessions" if out.get("sessions", 1) > 1 else ""
    changed = (
        f"; its budget changed from {out['budget_changed_from']} steps (--timesteps)"
        if "budget_changed_from" in out
        else ""
    )
    best = out.get("best")
    if best is not None:
        source = (
            f"best/ is the best of {out['evaluations']} evaluations (mean reward "
            f"{best['mean_reward']:.3g} at step {best['step']})"
        )
    else:
        source = (
            "best/ is the final policy: no evaluation ran (the first comes after --eval-freq "
            "steps; eval/ stays empty)"
        )
    return (
        f"trained {out['timesteps']} steps in {out['wall_time_s'] / 60:.1f} min{rate}{resumed}: "
        f"{out['out']} (final/, best/, logs/, eval/, summary.json){changed}; {source}"
    )


def cmd_evaluate(args) -> dict:
    policy_dir_arg(args.policy, "--policy")
    if args.env is not None:
        env_arg(args.env, "--env")
    episodes = count_arg(args.episodes, "--episodes")
    seed = seed_arg(args.seed, "--seed", episodes)
    env_kwargs = parse_json_arg(args.env_kwargs, "--env-kwargs")
    if args.meshcat and args.env is None:
        serving_policy_arg(args.policy, "evaluate --meshcat")
    elif args.meshcat:
        serves_arg(args.env, "evaluate --meshcat", f"--env {args.env}")
    from drake_tooluse.learning.evaluate import evaluate

    meshcat = open_meshcat(args)
    if meshcat is not None:  # the env draws its episodes there (its `meshcat` kwarg)
        env_kwargs = {**(env_kwargs or {}), "meshcat": meshcat}
    result = evaluate(
        args.policy,
        args.env,
        episodes,
        seed,
        env_kwargs,
        trust_pickle=args.trust_pickle,
        progress=not args.no_progress,
        to_time_limit=args.to_time_limit,
    ).as_dict()
    if not args.per_episode:
        result.pop("per_episode")
    if meshcat is not None:
        result["meshcat_url"] = meshcat.web_url()
    result["env_id"] = env_id = args.env or policy_env_id(args.policy)
    result["object_name"] = env_class(env_id).TASK.object_name  # the word the text prints
    return result


def cmd_convert_policy(args) -> dict:
    policy_dir_arg(args.policy, "--policy")
    if args.out.resolve() != args.policy.resolve():
        output_dir_arg(args.out, "--out")
    from drake_tooluse.learning.policy_dir import convert_policy, load_policy

    out = convert_policy(args.policy, args.out, trust_pickle=args.trust_pickle)
    load_policy(out)  # the new directory loads without pickles
    return {"converted": str(args.policy), "out": str(out)}


def format_convert_policy(out: dict) -> str:
    return f"converted {out['converted']} -> {out['out']} (loads without pickles)"


# distill's settings (DistillConfig's fields, bar env_kwargs, parsed from JSON): with --resume
# none is given (the distillation's own are used).
DISTILL_OPTIONS = (
    "action_mode",
    "init_from",
    "rounds",
    "episodes",
    "epochs",
    "learning_rate",
    "seed",
)
DISTILL_SETTINGS = ("teacher", "out", "env_kwargs", *DISTILL_OPTIONS)


def _flag(name: str) -> str:
    return "--" + name.replace("_", "-")


def cmd_distill(args) -> dict:
    from drake_tooluse.experiments.distill import PROGRESS, unfinished

    if args.resume is not None:
        given = [_flag(name) for name in DISTILL_SETTINGS if getattr(args, name) is not None]
        if given:
            raise UsageError(
                f"--resume goes on with the distillation's own settings; leave out {', '.join(given)}"
            )
        output_dir_arg(args.resume, "--resume", must_be_new=False)
        if not unfinished(args.resume):
            raise UsageError(
                f"--resume {str(args.resume)!r} holds no unfinished distillation (no {PROGRESS}): "
                "it finished, or is not a distillation's"
            )
        from drake_tooluse.experiments.distill import resume_distill

        return _resumable(args.resume, lambda log: resume_distill(args.resume, log=log))
    if args.teacher is None or args.out is None:
        raise UsageError("give --teacher and --out for a new distillation, or --resume DIR")
    if unfinished(args.out):
        raise UsageError(
            f"--out {str(args.out)!r} already holds an unfinished distillation; continue it "
            f"with --resume {str(args.out)!r}, or give a new --out"
        )
    config = _distill_config(args)
    command = shlex.join(["drake-tooluse", *sys.argv[1:]])
    from drake_tooluse.experiments.distill import distill

    return _resumable(args.out, lambda log: distill(args.teacher, args.out, config, command, log))


def _distill_config(args):
    """The DistillConfig of a new distillation's flags, each checked (defaults for those not
    given)."""
    from drake_tooluse.experiments.distill import STUDENT_MODES, DistillConfig, check_teacher
    from drake_tooluse.learning.policy_dir import load_policy
    from drake_tooluse.learning.task_envs import check_env_kwargs

    given = {name: getattr(args, name) for name in DISTILL_OPTIONS}
    config = DistillConfig(
        **{k: v for k, v in given.items() if v is not None},
        env_kwargs=parse_json_arg(args.env_kwargs, "--env-kwargs") or {},
    )
    serving_policy_arg(args.teacher, "distill", "--teacher")
    output_dir_arg(args.out, "--out")
    count_arg(config.rounds, "--rounds")
    count_arg(config.episodes, "--episodes")
    count_arg(config.epochs, "--epochs")
    seed_arg(config.seed, count=config.rounds * config.episodes)
    check_in_range(config.learning_rate, 1e-7, 1.0, "--learning-rate")
    choice_arg(config.action_mode, STUDENT_MODES, "--action-mode", "student action mode")
    teacher = load_policy(args.teacher)
    try:
        check_teacher(teacher)
    except ValueError as e:
        raise UsageError(f"--teacher {str(args.teacher)!r}: {e}") from None
    env_id = teacher.meta.env_id
    check_env_kwargs(env_id, {**teacher.meta.env_kwargs, **config.env_kwargs}, "--env-kwargs")
    if config.init_from is not None:
        policy_dir_arg(config.init_from, "--init-from")
    return config


def _resumable(out, run) -> dict:
    """`run(log)`, its rounds logged to stderr; stopped, it says how to go on."""
    from drake_tooluse.experiments.distill import round_text, unfinished

    try:
        return run(lambda r: print(round_text(r), file=sys.stderr))
    except KeyboardInterrupt:
        if not unfinished(out):
            raise
        raise KeyboardInterrupt(
            f"the rounds so far are saved in {str(out)!r}; go on with "
            f"`drake-tooluse distill --resume {shlex.quote(str(out))}`"
        ) from None


def format_distill(out: dict) -> str:
    last = out["rounds"][-1]
    return (
        f"distilled {out['teacher']} -> {out['out']}: {len(out['rounds'])} rounds, "
        f"{last['samples']} samples; the student's last round: success "
        f"{last['success']:.0%}, RMSE per action [{', '.join(f'{r:.3f}' for r in last['rmse'])}]; "
        f"{out['wall_time_s']:.0f} s"
    )


def format_flagged(out: dict) -> str:
    """The episodes past a physical limit, per flag, where there are any ("" if none)."""
    flagged = {k: n for k, n in out.get("flagged_episodes", {}).items() if n}
    if not flagged:
        return ""
    return "; past a physical limit: " + ", ".join(f"{k} in {n}" for k, n in flagged.items())


def format_evaluate(out: dict) -> str:
    ends = " (each run to the step limit)" if out.get("to_time_limit") else ""
    thing = out.get("object_name", "object")
    return (
        f"{out['episodes']} episodes from seed {out['seed']}{ends}: "
        + format_figures(out, thing)
        + (f"; {out['sim_errors']} simulation failure(s)" if out.get("sim_errors") else "")
        + format_flagged(out)
    )


def cmd_sweep(args) -> dict:
    count_arg(args.max_failures, "--max-failures")
    if args.num_cpus is not None:
        count_arg(args.num_cpus, "--num-cpus")
    if args.resume is not None:
        given = [
            f
            for f in ("algos", "envs", "seeds", "timesteps", "out", "hyperparams", "episodes")
            if getattr(args, f) is not None
        ]
        if given:
            raise UsageError(
                f"--resume reads the grid from {str(args.resume)!r}; leave out "
                + ", ".join("--" + f.replace("_", "-") for f in given)
            )
        from drake_tooluse.learning.sweep import results_table, sweep

        rows = sweep(
            out=args.resume,
            resume=True,
            address=args.address,
            num_cpus=args.num_cpus,
            max_failures=args.max_failures,
        )
        return {"runs": rows, "table": results_table(rows)}
    if args.out is None:
        raise UsageError("give --out (a new directory) or --resume OUT")
    timesteps = 300_000 if args.timesteps is None else args.timesteps
    episodes = 20 if args.episodes is None else args.episodes
    count_arg(timesteps, "--timesteps")
    count_arg(episodes, "--episodes")
    for algo in args.algos or []:
        choice_arg(algo, ALGOS, "--algos", "algorithm")
    for env in args.envs or []:
        env_arg(env, "--envs")
    seeds = [0] if args.seeds is None else args.seeds
    for seed in seeds:
        seed_arg(seed, "--seeds")
    output_dir_arg(args.out, "--out", must_be_new=False)
    overrides = parse_json_arg(args.hyperparams, "--hyperparams")
    from drake_tooluse.learning.sweep import results_table, sweep

    try:
        rows = sweep(
            args.algos or ["ppo"],
            args.envs or ["drake_tooluse/ToolPush-v1"],
            seeds,
            timesteps,
            args.out,
            address=args.address,
            num_cpus=args.num_cpus,
            overrides=overrides,
            episodes=episodes,
            max_failures=args.max_failures,
        )
    except FileExistsError as e:
        raise in_cli_words(e, args.out, "sweep") from None
    return {"runs": rows, "table": results_table(rows)}


def add_parsers(sub) -> None:
    p = sub.add_parser("train", help="train a policy with stable-baselines3 / sb3-contrib")
    p.add_argument(
        "--env", help=f"one of {task_env_ids()} (default: {DEFAULT_ENV}; with --resume, the run's)"
    )
    p.add_argument(
        "--algo", help=f"one of {list(ALGOS)} (default: {DEFAULT_ALGO}; with --resume, the run's)"
    )
    p.add_argument(
        "--timesteps",
        type=int,
        help=f"environment steps in all (default: {DEFAULT_TIMESTEPS}, a full training; `sweep` "
        "defaults to 300000 per cell, a comparison; with --resume, the run's own: another "
        "budget is applied, and the result says so)",
    )
    p.add_argument("--n-envs", type=int, help="parallel envs (default from the YAML)")
    p.add_argument(
        "--seed",
        type=int,
        help="seed of the envs and the policy (default: 0; with --resume, the run's)",
    )
    p.add_argument(
        "--out",
        type=Path,
        help="new run directory (refused if it holds a run that started: --resume continues it)",
    )
    p.add_argument(
        "--resume",
        type=Path,
        metavar="DIR",
        help="continue the run in DIR with its own settings (the flags that set them, given "
        "too, must match)",
    )
    p.add_argument(
        "--env-kwargs",
        metavar="JSON",
        help="env keyword arguments, over the YAML's (as `evaluate --env-kwargs`)",
    )
    p.add_argument(
        "--tool-length", type=float, metavar="L", help="the env's tool length (m, in (0, 0.60])"
    )
    p.add_argument("--scenario", type=Path, help="the env's scenario YAML")
    p.add_argument(
        "--init-from",
        type=Path,
        metavar="POLICY",
        help="start from a trained policy directory (fine-tuning)",
    )
    p.add_argument(
        "--hyperparams",
        metavar="JSON",
        help="override YAML hyperparameters, e.g. '{\"learning_rate\": 1e-4}'",
    )
    p.add_argument(
        "--eval-freq",
        type=int,
        metavar="N",
        help="evaluate every N steps in all (rl-zoo's name; the YAML's eval_freq)",
    )
    p.add_argument(
        "--save-freq",
        type=int,
        metavar="N",
        help="checkpoint every N steps in all (the YAML's checkpoint_freq)",
    )
    p.add_argument(
        "--n-eval-episodes",
        type=int,
        metavar="N",
        help="episodes per evaluation (the YAML's eval_episodes)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_train, show=format_train)

    p = sub.add_parser("evaluate", help="evaluate a policy directory over seeded episodes")
    p.add_argument("--policy", type=Path, required=True, help="policy directory")
    p.add_argument("--env", help="env id (default: the one it was trained on)")
    p.add_argument("--episodes", type=int, default=100, help="episodes to run")
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode (then +1 each)")
    p.add_argument("--env-kwargs", metavar="JSON", help="override env kwargs")
    p.add_argument("--per-episode", action="store_true", help="include each episode")
    p.add_argument(
        "--to-time-limit",
        action="store_true",
        help="run each episode on past a termination to its step limit and judge it where it "
        "ends, for an env that terminates (the project's envs never do: their episodes run to "
        "the limit either way)",
    )
    p.add_argument(
        "--no-progress",
        action="store_true",
        help="no progress bar (there is none either when stderr is not a terminal)",
    )
    add_meshcat_arg(p, "the episodes as they run")
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_evaluate, show=format_evaluate)

    p = sub.add_parser(
        "convert-policy",
        help="rewrite a policy directory of the older pickle format (policy.zip, "
        "vecnormalize.pkl) as one that loads without running code (needs --trust-pickle)",
    )
    p.add_argument("--policy", type=Path, required=True, help="the old policy directory")
    p.add_argument("--out", type=Path, required=True, help="new directory (or --policy itself)")
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_convert_policy, show=format_convert_policy)

    p = sub.add_parser(
        "distill",
        help="a policy of the paper's 7-d action (position_quaternion) from a push policy of "
        "the position action, by DAgger (experiments.distill); fine-tune it with train --init-from",
    )
    p.add_argument("--teacher", type=Path, help="the position policy directory")
    p.add_argument("--out", type=Path, help="new policy directory")
    p.add_argument(
        "--resume",
        type=Path,
        metavar="DIR",
        help="go on with a stopped distillation in DIR (its --out), from its last round",
    )
    p.add_argument(
        "--action-mode",
        help="the student's: position_quaternion (the paper's 7-d action, the default) or position",
    )
    p.add_argument(
        "--env-kwargs", metavar="JSON", help="the student's env kwargs, over the teacher's"
    )
    p.add_argument(
        "--init-from",
        type=Path,
        help="go on from the student of an earlier distill (same teacher and options)",
    )
    p.add_argument("--rounds", type=int, help="DAgger rounds (default: 16)")
    p.add_argument("--episodes", type=int, help="episodes per round (default: 60)")
    p.add_argument("--epochs", type=int, help="passes over the data per round (default: 20)")
    p.add_argument(
        "--learning-rate", type=float, help="Adam's, fitting the student (default: 3e-4)"
    )
    seed_help = (
        "seed of the first episode (then +1 each), the noise and the fitting (default: 7000)"
    )
    p.add_argument("--seed", type=int, help=seed_help)
    p.set_defaults(run=cmd_distill, show=format_distill)

    p = sub.add_parser(
        "sweep",
        help="a grid of runs (algos x envs x seeds) on Ray Tune, local or on a cluster "
        "(pip install '.[cluster]')",
    )
    p.add_argument("--algos", nargs="+", help=f"algorithms, of {list(ALGOS)} (default: ppo)")
    p.add_argument("--envs", nargs="+", help="env ids (default: drake_tooluse/ToolPush-v1)")
    p.add_argument("--seeds", type=int, nargs="+", help="one run per seed (default: 0)")
    p.add_argument("--timesteps", type=int, help="environment steps per run (default: 300000)")
    p.add_argument("--out", type=Path, help="new directory for the runs and the table")
    p.add_argument(
        "--resume",
        type=Path,
        metavar="OUT",
        help="continue the sweep in OUT: finished cells are kept, the others continue from "
        "their last checkpoint",
    )
    p.add_argument(
        "--address",
        help="join this Ray cluster, e.g. auto or HEAD_IP:6379 (default: a local one)",
    )
    p.add_argument("--num-cpus", type=int, help="CPUs of the local Ray (default: all)")
    p.add_argument(
        "--max-failures",
        type=int,
        default=2,
        help="times a failed cell (a lost node, a crash) is retried from its checkpoint",
    )
    p.add_argument("--hyperparams", metavar="JSON", help="override YAML hyperparameters")
    p.add_argument("--episodes", type=int, help="evaluation episodes per run (default: 20)")
    p.set_defaults(
        run=cmd_sweep,
        show=lambda out: out["table"].rstrip("\n"),
        status=lambda out: (
            EXIT_NOT_REACHED if any(r["status"] != "finished" for r in out["runs"]) else EXIT_OK
        ),
    )
