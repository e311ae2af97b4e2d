"""`trajectory`, `export-csv`, `transfer`, `demo` and `record-video`: the paper's experiments,
and an episode to show; `choose-tool`: the robot chooses its tool from a rack."""

from __future__ import annotations

import math
import time
from pathlib import Path

from drake_tooluse.cli.common import (
    UsageError,
    add_meshcat_arg,
    add_renamed_option,
    add_trust_pickle_arg,
    choice_arg,
    count_arg,
    open_meshcat,
    output_dir_arg,
    output_file_arg,
    policy_dir_arg,
    policy_env_id,
    seed_arg,
    serves_arg,
    serving_policy_arg,
    tool_length_arg,
)
from drake_tooluse.experiments.choices import (
    ALIGNMENTS,
    CALIBRATION_DRAWS,
    DEFAULT_ROLLOUTS,
    EXTRACTIONS,
    MODES,
    RECORDS,
    check_tool_kinds,
    task_tools,
    transfer_tool,
)
from drake_tooluse.experiments.parallel import available_cores
from drake_tooluse.paths import DEFAULT_SCENARIO, REALITY_SCENARIO, TRANSFER_POLICY
from drake_tooluse.tasks.contract import tool_tasks
from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS


def cmd_trajectory(args) -> dict:
    length = tool_length_arg(args.tool_length)
    choice_arg(args.extraction, EXTRACTIONS, "--extraction", "extraction")
    choice_arg(args.align, ALIGNMENTS, "--align", "alignment")
    if args.tip_poses is not None:
        choice_arg(args.tip_poses, RECORDS, "--tip-poses", "kind of tip poses")
    episodes = count_arg(args.episodes, "--episodes")
    seed_arg(args.seed, "--seed", episodes)
    count_arg(args.window, "--window")
    count_arg(args.calibration_draws, "--calibration-draws")
    output_dir_arg(args.out, "--out")  # a new directory, as every command's result directory
    serving_policy_arg(args.policy, "trajectory")
    from drake_tooluse.experiments.choices import EXTRACTION_RECORDS
    from drake_tooluse.experiments.line_contact import line_contact_for_task
    from drake_tooluse.experiments.trajectory_extraction import extract, save_extraction
    from drake_tooluse.world.scenario import load_scenario

    start = time.perf_counter()
    line = args.extraction == "line-contact"
    scenario = load_scenario(args.scenario) if line else None  # a bad file fails before work
    ex = extract(
        args.policy,
        args.episodes,
        args.seed,
        args.window,
        length,
        align=args.align,
        trust_pickle=args.trust_pickle,
        record=args.tip_poses or EXTRACTION_RECORDS[args.extraction],
        box_frame=line,
    )
    contact = (
        line_contact_for_task(
            ex.smoothed, length, scenario, calibration_draws=args.calibration_draws
        )
        if line
        else None
    )
    path, figure = save_extraction(ex, args.out, None if contact is None else contact.trajectory)
    r = ex.reachability
    return {
        "extraction": args.extraction,
        "episodes": args.episodes,
        "successes": ex.successes,
        "steps": r.poses,
        "reachable_before_filter": r.poses,
        "reachable_after_filter": r.reachable if contact is None else contact.reachable,
        "dropped_steps": r.dropped_indices if contact is None else [],
        **({} if contact is None else {"line_contact": contact.as_dict()}),
        "trajectory": str(path),
        "figure": str(figure),
        "wall_time_s": time.perf_counter() - start,
    }


def format_trajectory(out: dict) -> str:
    from drake_tooluse.experiments.line_contact import describe_choice

    dropped = len(out["dropped_steps"])
    contact = out.get("line_contact")
    how = (
        f"; line contact, the tool tilted {contact['tilt_deg']} deg"
        + ("" if contact["followed"] else " (the IK jumps on it from some box starts)")
        + describe_choice(contact)
        + ", for the nominal box start"
        if contact
        else ""
    )
    return (
        f"{out['episodes']} episodes ({out['successes']} reached the goal) averaged into "
        f"{out['steps']} tip poses, {out['reachable_after_filter']} kept"
        + (f" ({dropped} unreachable dropped)" if dropped else "")
        + how
        + f": {out['trajectory']}, {out['figure']} ({out['wall_time_s']:.0f} s)"
    )


def cmd_export_csv(args) -> dict:
    from drake_tooluse.validation import check_in_range

    length = tool_length_arg(args.tool_length)
    scale = check_in_range(args.time_scale, 0.1, 100.0, "--time-scale")
    output_file_arg(args.out, "--out")
    from drake_tooluse.experiments.baxter_csv import (
        check_clearance,
        check_left_arm,
        export_baxter_csv,
        velocity_excess,
    )
    from drake_tooluse.experiments.trajectory_extraction import filter_reachable
    from drake_tooluse.systems.tip_trajectory import TipTrajectory
    from drake_tooluse.world.scenario import load_scenario

    left_q = check_left_arm(args.left_arm_q, "--left-arm-q")
    traj = TipTrajectory.load(args.trajectory)
    report = filter_reachable(traj, length)
    if report.dropped_indices:
        times = [round(float(traj.times[i]), 3) for i in report.dropped_indices[:10]]
        raise ValueError(
            f"{len(report.dropped_indices)} of {report.poses} poses of "
            f"{str(args.trajectory)!r} are unreachable with a {length} m tool under "
            f"the conservative joint limits (at t = {times} s …); nothing written"
        )
    times = (report.kept.times - report.kept.times[0]) * scale
    slowdown, fastest = velocity_excess(times, report.joint_positions)
    if slowdown > 1.0:
        # Joint speeds scale as 1 / --time-scale: round the smallest passing scale up.
        smallest = math.ceil(scale * slowdown * 100 * (1 + 1e-9)) / 100
        raise ValueError(
            f"at --time-scale {scale:g} {fastest}; the smallest --time-scale that keeps "
            f"every joint within its velocity limit is {smallest:g}; nothing written"
        )
    table = load_scenario(args.scenario).table
    clearance = check_clearance(report.joint_positions, left_q, length, table, times=times)
    path = export_baxter_csv(args.out, times, report.joint_positions, left_q)
    return {
        "csv": str(path),
        "rows": len(times),
        "duration_s": float(times[-1]),
        "left_arm_q": list(left_q),
        "clearance": clearance,
    }


def format_export_csv(out: dict) -> str:
    c = out["clearance"]
    return (
        f"{out['csv']}: {out['rows']} rows, {out['duration_s']:.2f} s; smallest clearances: "
        f"arms {c['arms_m'] * 100:.1f} cm, table {c['table_m'] * 100:.1f} cm, tool tip above "
        f"the table {c['tool_tip_above_table_m'] * 100:.1f} cm"
    )


def cmd_transfer(args) -> dict:
    """Runs the experiment into a new directory (transfer.json, the box plot)."""
    from drake_tooluse.experiments.runs import new_run_dir

    choice_arg(args.mode, MODES, "--mode", "mode")
    choice_arg(args.align, ALIGNMENTS, "--align", "alignment")
    if args.tip_poses is not None:
        choice_arg(args.tip_poses, RECORDS, "--tip-poses", "kind of tip poses")
    choice_arg(args.extraction, EXTRACTIONS, "--extraction", "extraction")
    out = output_dir_arg(args.out or new_run_dir(f"transfer-{args.mode}"), "--out")
    runs = count_arg(args.runs, "--runs")
    seed_arg(args.seed, "--seed", runs)
    count_arg(args.episodes, "--episodes")
    count_arg(args.calibration_draws, "--calibration-draws")
    policy = serving_policy_arg(args.policy, "transfer")
    env_id = policy_env_id(policy)
    if args.mode == "open-loop":  # it replays the policy's tool-tip trajectory
        serves_arg(env_id, "trajectory", f"--mode open-loop --policy {policy}")
    try:
        tools = [transfer_tool(t) for t in args.tools or task_tools(env_id)]
        check_tool_kinds(env_id, tools)
    except ValueError as e:
        raise UsageError(f"--tools: {e}") from None
    from drake_tooluse.experiments.transfer import transfer_experiment

    return transfer_experiment(
        out,
        args.policy,
        tools,
        args.runs,
        args.mode,
        args.seed,
        args.nominal,
        args.reality,
        args.trajectory,
        args.episodes,
        args.align,
        use_grasp_estimate=not args.length_only,
        trust_pickle=args.trust_pickle,
        record=args.tip_poses,
        extraction=args.extraction,
        calibration_draws=args.calibration_draws,
    )


def format_transfer(out: dict) -> str:
    from drake_tooluse.experiments.transfer import format_transfer as format_result

    return format_result(out)


def cmd_demo(args) -> dict:
    from drake_tooluse.experiments.runs import new_run_dir

    if args.tool is not None and args.tool_length is not None:
        raise UsageError("give --tool or --tool-length (a straight tool), not both")
    tool = args.tool
    if args.tool_length is not None:
        tool = f"straight:{tool_length_arg(args.tool_length)}"
    seed_arg(args.seed)
    from drake_tooluse.experiments.demo import RANDOM, SCRIPTED, run_demo
    from drake_tooluse.robot.tool import parse_tool

    try:
        tool = None if tool in (None, RANDOM) else parse_tool(tool)
    except ValueError as e:
        raise UsageError(f"--tool: {e}; or random") from None
    tool = RANDOM if args.tool == RANDOM else tool
    if args.policy is not None and str(args.policy) != SCRIPTED:
        policy_dir_arg(args.policy, "--policy")
    out = output_dir_arg(args.out or new_run_dir("demo"), "--out")
    meshcat = open_meshcat(args)
    try:
        result = run_demo(
            out,
            args.task,
            args.policy,
            tool,
            args.scenario,
            args.seed,
            progress=not args.no_progress,
            trust_pickle=args.trust_pickle,
            meshcat=meshcat,
        )
    # A tool the task has no way to use, or a policy of another task: before anything is written.
    except ValueError as e:
        raise UsageError(str(e).splitlines()[0]) from None
    return result if meshcat is None else {**result, "meshcat_url": meshcat.web_url()}


def format_demo(out: dict) -> str:
    from drake_tooluse.experiments.demo import format_demo as format_result

    return format_result(out)


def cmd_choose_tool(args) -> dict:
    rollouts = count_arg(args.rollouts, "--rollouts")
    workers = count_arg(args.workers, "--workers")
    seed_arg(args.seed)
    from drake_tooluse.experiments.tool_choice import DEFAULT_RACK, choose_tool, generated_rack

    if args.record is not None:
        output_file_arg(args.record, "--record", ".html")
    rack = args.tools or DEFAULT_RACK
    if args.rack_seed is not None:
        if args.tools:
            raise UsageError("--rack-seed draws the rack: give no --tools with it")
        rack = generated_rack(seed_arg(args.rack_seed, "--rack-seed"))
    return choose_tool(
        args.task,
        rack,
        rollouts,
        args.seed,
        oracle=args.oracle,
        delay_margin=args.delay_margin,
        recording_path=args.record,
        workers=workers,
    )


def format_choose_tool(out: dict) -> str:
    from drake_tooluse.experiments.tool_choice import format_choice

    return format_choice(out)


def add_tip_poses_arg(p, when: str = "") -> None:
    """--tip-poses: which tip poses of the episodes are averaged (once `--record`, a name
    `simulate` gives its Meshcat recording file: refused here, naming this one)."""
    p.add_argument(
        "--tip-poses",
        metavar="KIND",
        help=f"{when}the episodes' tip poses averaged: 'achieved' (where the tip got: the "
        "paper's) or 'commanded' (the tip pose each step commanded, which the arm lags by up to "
        "~2 cm); default the extraction's own",
    )
    add_renamed_option(
        p,
        "--record",
        "--record is now --tip-poses (achieved or commanded); --record names a Meshcat "
        "recording file, in `simulate`",
    )


def cmd_record_video(args) -> dict:
    output_file_arg(args.out, "--out", ".gif")
    seed_arg(args.seed)
    count_arg(args.every, "--every")
    count_arg(args.colors, "--colors")
    serving_policy_arg(args.policy, "record-video")
    env_kwargs = {  # checked by the env, by these names (`render_size=...`)
        name: value
        for name, value in (
            ("render_size", args.render_size),
            ("render_camera_position", args.render_camera_position),
            ("render_camera_target", args.render_camera_target),
        )
        if value is not None
    }
    from drake_tooluse.experiments.video import record_video

    return record_video(
        args.policy,
        args.out,
        args.seed,
        every=args.every,
        colors=args.colors,
        env_kwargs=env_kwargs,
        trust_pickle=args.trust_pickle,
        progress=True,
    )


# What record-video's result holds beside the episode's figures (the task's metrics).
VIDEO_KEYS = ("video", "policy", "seed", "frames", "fps", "size_px", "bytes", "steps", "success")


def format_record_video(out: dict) -> str:
    from drake_tooluse.learning.figures import format_figures

    figures = format_figures(
        {k: v for k, v in out.items() if k not in VIDEO_KEYS}, out.get("object_name", "object")
    )
    where = f"; {figures}" if figures else ""
    return (
        f"{out['video']}: {out['frames']} frames of {out['size_px'][0]} x {out['size_px'][1]} px "
        f"at {out['fps']:g} fps, {out['bytes'] / 1000:.0f} KB; seed {out['seed']}, "
        f"{out['steps']} steps, {'success' if out['success'] else 'no success'}{where}"
    )


def add_calibration_arg(p) -> None:
    p.add_argument(
        "--calibration-draws",
        type=int,
        default=CALIBRATION_DRAWS,
        metavar="N",
        help="line contact: move the trajectory across the push to where it pushes best over N "
        "randomized replays in the nominal simulation, per offset tried (0: the geometric "
        "centring only; default %(default)s)",
    )


def add_parsers(sub) -> None:
    p = sub.add_parser(
        "trajectory",
        help="record a policy's episodes and average them into a "
        "tool-tip trajectory (the paper's transfer input)",
    )
    p.add_argument("--policy", type=Path, required=True, help="policy directory")
    p.add_argument("--episodes", type=int, default=100, help="episodes averaged")
    p.add_argument("--seed", type=int, default=0, help="seed of the first episode (then +1 each)")
    p.add_argument("--window", type=int, default=5, help="smoothing window (odd, steps)")
    p.add_argument(
        "--extraction",
        default="line-contact",
        help="'line-contact' (the episodes in their boxes' frame, the push centred on the box, "
        "the tool tilted so that its shaft pushes: for the scenario's nominal box start, as "
        "`transfer --mode open-loop` replays it) or 'mean-achieved' (the paper's per-step mean of where the "
        "tip got)",
    )
    p.add_argument(
        "--align",
        default="start",
        help="'start' (the paper's: step by step from the start) or 'contact' "
        "(from the tool's first touch of the box)",
    )
    add_tip_poses_arg(p)
    p.add_argument(
        "--scenario",
        type=Path,
        default=DEFAULT_SCENARIO,
        help="line contact: the scenario whose box start the trajectory is placed at and "
        "whose box it is centred on (default: %(default)s, the nominal world; the episodes "
        "are the policy's env's, averaged in their box's frame)",
    )
    p.add_argument(
        "--tool-length",
        type=float,
        default=PAPER_TOOL_LENGTHS[1],
        help="tool for the reachability filter (m)",
    )
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help="new directory (absent or empty) for trajectory.npz and trajectory.png",
    )
    add_calibration_arg(p)
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_trajectory, show=format_trajectory)

    p = sub.add_parser("export-csv", help="a tool-tip trajectory as a Baxter SDK playback CSV")
    p.add_argument("--trajectory", type=Path, required=True, help="trajectory .npz")
    p.add_argument("--tool-length", type=float, required=True, help="the tool held (m)")
    p.add_argument("--out", type=Path, required=True, help="CSV file to write")
    p.add_argument(
        "--time-scale",
        type=float,
        default=1.0,
        help="stretch time by this factor (slower is safer)",
    )
    p.add_argument(
        "--left-arm-q",
        type=float,
        nargs=7,
        metavar="RAD",
        help="where the left arm stays, s0 … w2 (rad; default the safe pose Rethink's "
        "tuck_arms.py tucks it to, folded against the body); checked against the right arm, "
        "its tool and the table over the whole trajectory",
    )
    p.add_argument(
        "--scenario",
        type=Path,
        default=DEFAULT_SCENARIO,
        help="scenario YAML whose table the arms are checked against (default: %(default)s)",
    )
    p.set_defaults(run=cmd_export_csv, show=format_export_csv)

    p = sub.add_parser(
        "transfer",
        help="use a learned skill with other tools in the "
        "perturbed 'reality' world (diagrams/reality.yaml)",
    )
    p.add_argument("--policy", type=Path, default=TRANSFER_POLICY, help="policy directory")
    p.add_argument(
        "--tools",
        nargs="+",
        metavar="TOOL",
        help="the true tools, of the kind the policy uses: straight tools' lengths (m, or "
        "straight:L), hooks as hook:HANDLE,HOOK,ANGLE (m, m, deg) (default: the policy's "
        f"task's; the push's are the paper's lengths {' '.join(map(str, PAPER_TOOL_LENGTHS))})",
    )
    p.add_argument("--runs", type=int, default=10, help="runs per tool (seeds seed … seed+runs-1)")
    p.add_argument("--mode", default="closed-loop", help="closed-loop or open-loop")
    p.add_argument("--seed", type=int, default=0, help="seed of the first run (then +1 each)")
    p.add_argument(
        "--trajectory",
        type=Path,
        metavar="NPZ",
        help="open loop: replay this trajectory, for every tool (`drake-tooluse trajectory` "
        "writes one): with --extraction line-contact it is taken as made for the nominal box "
        "start and replayed at each run's, with --extraction paper as it is (default: extract "
        "one per tool from the policy's --episodes episodes)",
    )
    p.add_argument(
        "--episodes",
        type=int,
        default=100,
        help="open loop: episodes averaged into the trajectory",
    )
    p.add_argument(
        "--align",
        default="start",
        help="open loop: average the episodes step by step from their start "
        "('start', the paper's) or from the tool's first touch of the box "
        "('contact')",
    )
    p.add_argument(
        "--extraction",
        default="line-contact",
        help="open loop: how the trajectory is made of the episodes: 'line-contact' (the "
        "commanded tip poses in each box's frame, the tool tilted per tool so that its shaft "
        "pushes, replayed at each run's box start, measured by the hand camera) or 'mean-achieved' "
        "(the per-step mean of where the tip got, replayed as it is)",
    )
    add_tip_poses_arg(p, "open loop: ")
    add_calibration_arg(p)
    p.add_argument(
        "--nominal",
        type=Path,
        help="nominal scenario YAML (default: the policy's task's world, for the push "
        f"{DEFAULT_SCENARIO.name})",
    )
    p.add_argument(
        "--reality",
        type=Path,
        help="reality scenario YAML (default: the policy's task's reality, for the push "
        f"{REALITY_SCENARIO.name})",
    )
    p.add_argument(
        "--length-only",
        action="store_true",
        help="the robot's model takes only the measured length (the paper's "
        "measurement), not the camera's estimate of the grasp along the tool",
    )
    p.add_argument(
        "--out",
        type=Path,
        help="directory for transfer.json and the box plot (default runs/transfer-<mode>-<time>)",
    )
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_transfer, show=format_transfer)

    p = sub.add_parser(
        "choose-tool",
        help="measure each tool of a rack, predict its success in simulation, choose the "
        "best and do the task with it in the perturbed reality",
    )
    p.add_argument("--task", default="pull", help="push, push-far or pull (default pull)")
    p.add_argument("--seed", type=int, default=0, help="the task instance's draw")
    p.add_argument(
        "--tools",
        nargs="+",
        metavar="TOOL",
        help="the rack, 1-5 tools: straight:L (m) or hook:HANDLE,HOOK,ANGLE (m, m, deg) "
        "(default: straight:0.03 straight:0.3 hook:0.25,0.05,90 hook:0.35,0.08,60)",
    )
    p.add_argument(
        "--rack-seed",
        type=int,
        metavar="S",
        help="instead, a rack of five generated tools of five families that no policy "
        "trained with, drawn with S; each measured by its shape before the choice",
    )
    p.add_argument(
        "--rollouts", type=int, default=DEFAULT_ROLLOUTS, help="predicted rollouts per tool"
    )
    p.add_argument(
        "--workers",
        type=int,
        default=available_cores(),
        help="processes running the rollouts (default: this machine's cores, %(default)s)",
    )
    p.add_argument("--oracle", action="store_true", help="also run every tool in reality")
    p.add_argument(
        "--record",
        type=Path,
        metavar="HTML",
        help="write the chosen tool's run in reality as a Meshcat recording (standalone HTML)",
    )
    p.add_argument(
        "--delay-margin",
        type=float,
        default=0.06,
        metavar="S",
        help="the rollouts' actuation delays span 0 to this (s, in [0, 0.2], multiples of "
        "0.02 taken); 0: the plain nominal world",
    )
    p.set_defaults(run=cmd_choose_tool, show=format_choose_tool)

    p = sub.add_parser(
        "demo",
        help="measure an unseen tool and do a task with it (the shipped policy, in the "
        "perturbed reality), recorded",
    )
    p.add_argument(
        "--task",
        choices=tuple(tool_tasks()),
        default="push",
        help="the task, as its package declares it (default push: the box; pull: the cube, "
        "with a hook)",
    )
    p.add_argument(
        "--tool",
        metavar="SPEC",
        help="the true tool, straight:L or hook:HANDLE,HOOK,ANGLE (m, m, deg; default: the "
        "task's, straight:0.125 or hook:0.25,0.05,75), or random: a tool the robot has never "
        "seen, drawn with --seed from the tool generator's held-out family (the rake) and "
        "measured by its shape",
    )
    p.add_argument(
        "--tool-length",
        type=float,
        metavar="L",
        help="a straight tool of L m, in (0, 0.60] (--tool straight:L)",
    )
    p.add_argument(
        "--policy",
        type=Path,
        help="a policy directory of the task (default: its shipped policy), or `scripted` for "
        "its scripted reference",
    )
    p.add_argument("--scenario", type=Path, help="reality scenario (default: the task's reality)")
    p.add_argument("--seed", type=int, default=0, help="draw of the reality and camera noise")
    p.add_argument("--out", type=Path, help="new directory (default runs/demo-<time>)")
    p.add_argument("--no-progress", action="store_true", help="no progress lines on stderr")
    add_meshcat_arg(p, "the task's run (its recording, to play again)")
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_demo, show=format_demo)

    p = sub.add_parser(
        "record-video",
        help="one episode of a policy as an animated GIF (the scene camera: robot, tool, box "
        "and the goal in view)",
    )
    p.add_argument(
        "--policy",
        type=Path,
        default=TRANSFER_POLICY,
        help="policy directory (default: %(default)s)",
    )
    p.add_argument("--out", type=Path, required=True, help="the .gif file to write")
    p.add_argument("--seed", type=int, default=0, help="the episode's seed")
    p.add_argument(
        "--every",
        type=int,
        default=2,
        metavar="N",
        help="a frame every N control steps (40 ms each; the GIF plays in real time)",
    )
    p.add_argument(
        "--colors", type=int, default=96, help="colours of the GIF's one palette, in [2, 256]"
    )
    p.add_argument(
        "--render-size",
        type=int,
        nargs=2,
        metavar=("W", "H"),
        help="image width and height in px, each in [32, 2048] (default: the env's, 640 480)",
    )
    p.add_argument(
        "--render-camera-position",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="camera position in the world, m (default: the env's, framing the task)",
    )
    p.add_argument(
        "--render-camera-target",
        type=float,
        nargs=3,
        metavar=("X", "Y", "Z"),
        help="the point the camera looks at, m (default: the env's)",
    )
    add_trust_pickle_arg(p)
    p.set_defaults(run=cmd_record_video, show=format_record_video)
