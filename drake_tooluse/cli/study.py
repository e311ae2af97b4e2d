"""`study` and `study-report`: the paper's study at its scale, as a resumable job, and its page."""

from __future__ import annotations

from pathlib import Path

from drake_tooluse.cli.common import (
    EXIT_NOT_REACHED,
    EXIT_OK,
    UsageError,
    count_arg,
    goes_on_with,
    output_dir_arg,
    seed_arg,
    this_command,
)


def _files(args):
    """The study's files: under --out (default runs/study), or a checkout's docs
    (--update-docs: the current directory is the checkout)."""
    from drake_tooluse.experiments.paper_study_cells import DEFAULT_OUT, StudyFiles

    if args.runs_dir is not None:
        output_dir_arg(args.runs_dir, "--runs-dir", must_be_new=False)
    if args.update_docs:
        if args.out is not None:
            raise UsageError("give --out DIR or --update-docs, not both")
        return StudyFiles.docs(Path.cwd(), args.runs_dir)
    out = args.out if args.out is not None else DEFAULT_OUT
    output_dir_arg(out, "--out", must_be_new=False)
    return StudyFiles.under(out.absolute(), args.runs_dir)


def _file_options(args) -> list[str]:
    """The options that name the study's files, for the report the job makes."""
    options = ["--update-docs"] if args.update_docs else ["--out", str(_files(args).page.parent)]
    if args.cells is not None:
        options += ["--cells", str(args.cells.absolute())]
    return options


def _cells(args):
    from drake_tooluse.experiments.paper_study_cells import load_cells
    from drake_tooluse.paths import PAPER_STUDY_CELLS

    return load_cells(args.cells if args.cells is not None else PAPER_STUDY_CELLS)


def cmd_study(args) -> dict:
    count_arg(args.parallel, "--parallel")
    for seed in args.seeds or []:
        seed_arg(seed, "--seeds")
    if args.archive_every is not None and not 0 < args.archive_every <= 7 * 24 * 3600:
        raise UsageError(f"--archive-every {args.archive_every}: seconds in (0, 604800]")
    from drake_tooluse.experiments.paper_study_cells import (
        check_cell_names,
        unreported,
    )

    cells, episodes, evaluation_seed = _cells(args)
    check_cell_names(cells, args.only)
    files = _files(args)
    why_no_report = None if args.no_report else unreported(cells)
    if why_no_report and args.update_docs:  # the docs' page is the paper's
        raise UsageError(f"--update-docs: {why_no_report}")
    from drake_tooluse.experiments.paper_study import (
        ARCHIVE_EVERY,
        Study,
        queue_of,
        read_results,
        report_command,
        run_study,
        status,
    )

    study = Study(
        cells,
        files,
        episodes,
        evaluation_seed,
        archive_every=args.archive_every or ARCHIVE_EVERY,
        report_command=None
        if args.no_report or why_no_report
        else report_command(_file_options(args)),
    )
    if why_no_report and not args.states_only:
        study.log(f"no report (the paper's page): {why_no_report}")
    if args.states_only:
        runs = queue_of(study, args.only, args.seeds)
        return {"runs": status(study, read_results(files.results), runs), "states_only": True}
    kept = f"the runs so far are recorded in {str(files.results)!r} and kept"
    with goes_on_with(this_command(args), kept):  # a rerun picks up every run where it stopped
        return {"runs": run_study(study, args.only, args.seeds, args.parallel)}


def format_study(out: dict) -> str:
    from drake_tooluse.experiments.paper_study import format_status

    return format_status(out["runs"])


def cmd_study_report(args) -> dict:
    count_arg(args.trajectories, "--trajectories")
    cells, _, _ = _cells(args)
    from drake_tooluse.experiments.paper_study_cells import unreported

    why_not = unreported(cells)
    if why_not:
        raise UsageError(why_not)
    files = _files(args)
    from drake_tooluse.experiments.paper_study_report import make_report, page_is_current

    if args.check:
        if not page_is_current(cells, files):
            raise UsageError(
                f"{files.page} is not the page of {files.results}; make it again with "
                f"`drake-tooluse study-report {' '.join(_file_options(args))}`"
            )
        return {"current": True, "page": str(files.page)}
    return make_report(cells, files, args.trajectories)


def format_study_report(out: dict) -> str:
    if out.get("current"):
        return f"{out['page']}: current"
    figures = ", ".join(out["figures"]) or "no figures (no cell has finished runs)"
    return f"{out['table']}\nwrote {out['page']} and {figures}"


def _add_file_args(p) -> None:
    p.add_argument(
        "--out",
        type=Path,
        help="the study's directory: its results, the runs' archive, the runs and the page "
        "(default: runs/study)",
    )
    p.add_argument(
        "--update-docs",
        action="store_true",
        help="the checkout's docs instead (run in its root): docs/results/paper_study.json, "
        "the archive docs/results/paper_study/, docs/TRAINING.md, docs/figures/; the runs in "
        "runs/paper",
    )
    p.add_argument(
        "--cells",
        type=Path,
        metavar="FILE",
        help="a study file of other cells (default: the paper's, "
        "drake_tooluse/experiments/paper_study.yaml)",
    )


def add_parsers(sub) -> None:
    p = sub.add_parser(
        "study",
        help="the paper's study (cells x seeds: train, then evaluate), a job that resumes "
        "where it stopped and archives each run's small files",
    )
    _add_file_args(p)
    p.add_argument(
        "--runs-dir", type=Path, metavar="DIR", help="the run directories (default: see --out)"
    )
    p.add_argument(
        "--status",
        action="store_true",
        dest="states_only",  # (`args.status` is the command's exit status)
        help="print where each run stands; run none",
    )
    p.add_argument("--only", nargs="+", metavar="CELL", help="these cells (default: all)")
    p.add_argument("--seeds", type=int, nargs="+", help="only these seeds of each cell")
    p.add_argument(
        "--parallel",
        type=int,
        default=1,
        help="runs at a time: more where runs leave cores idle",
    )
    p.add_argument(
        "--archive-every",
        type=float,
        metavar="S",
        help="seconds between two archives of a run that trains (default: 1200)",
    )
    p.add_argument("--no-report", action="store_true", help="do not make the page after each run")
    p.set_defaults(
        run=cmd_study,
        show=format_study,
        status=lambda out: (
            EXIT_NOT_REACHED
            if not out.get("states_only") and any("error" in r for r in out["runs"])
            else EXIT_OK
        ),
    )

    p = sub.add_parser(
        "study-report",
        help="the study's page (TRAINING.md: statistics over seeds with rliable) and figures, "
        "from its results (pip install '.[bench]')",
    )
    _add_file_args(p)
    p.set_defaults(runs_dir=None)
    p.add_argument("--trajectories", type=int, default=10, help="episodes per 3-D panel")
    p.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 2 if the page is not what the results give (its list of "
        "runs still to run aside: that is of the machine's run directories)",
    )
    p.set_defaults(run=cmd_study_report, show=format_study_report)
