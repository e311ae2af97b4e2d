"""Every command line in README.md, docs/*.md and the user guide (docs/guide/*.md) works as
written, with small budgets.

The lines are those of the fenced ```bash blocks (a trailing backslash joins two lines; a `#`
starts a comment). A line is split at `&&` into commands, and every command must match one
rule of `RULES` below (a test fails on a line no rule covers, so a new line needs one):

- **install** (`python3 -m venv`, `. .venv/bin/activate`, `pip install ...`): not run — it
  would change the environment the tests run in; what it names must exist instead: each extra
  in pyproject.toml's `optional-dependencies`, and the torch requirement must be pyproject's.
- **suite** (`python -m pytest`): the suite this file is part of; not run again inside it.
- **covered**: run by the named test elsewhere (a study of hours, a Ray cluster's `ray start`);
  the test must exist.
- **server** (`tensorboard`): started, and it must say where it serves within 60 s; then
  stopped.
- **run**: everything else, in a scratch directory (the tests' runs/ lands there) holding
  copies of benchmarks/ and docs/, so that a script writing docs/results/ or docs/*.md
  (`--update-docs`) writes the copies, never the checkout. A relative path that exists in the
  checkout (diagrams/…, models/policies/…, drake_tooluse/…) reads the checkout's. Budgets
  shrink: each flag of `BUDGETS` present in a command has its values replaced (`--timesteps
  1250000` → `--timesteps 256`, `--episodes 100` → `--episodes 2`, `--runs 10` → `--runs 1`,
  `--rounds 20` → `--rounds 1`, `--seeds 0 1 2` and `--tools 0.25 0.3` keep their first
  value, …), and a rule may add flags (`train` gets small rollouts and
  an evaluation every 128 steps, so that `best/` exists for the `evaluate` line after it).
  The command must exit 0.

A block's lines run in order in one scratch directory per file; a block that reads a runs/
path an earlier block of its file writes (`evaluate --policy runs/ppo/best` after `train --out
runs/ppo`) runs that block first, if it has not run. A block with a slow command is marked
slow (run with `python -m pytest -m slow tests/docs/test_command_lines.py`, as CI does); the
coverage and install checks and the IK lines run in the default suite.
"""

from __future__ import annotations

import itertools
import os
import re
import shlex
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# The README and every page of the docs site (docs/conf.py) that holds command lines.
DOCS = [
    ROOT / "README.md",
    *sorted((ROOT / "docs").glob("*.md")),
    *sorted((ROOT / "docs" / "guide").glob("*.md")),
]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())
TIMEOUT_S = 1800  # one command; the slowest here (transfer_experiments.py) takes ~5 min

FIRST = None  # a budget that keeps the first of the values given
# flag -> the values it gets instead of those given (all of them).
BUDGETS = {
    "--timesteps": ["256"],
    "--episodes": ["2"],
    "--runs": ["1"],
    "--seeds": FIRST,
    "--tools": FIRST,
    "--tilts": FIRST,
    "--offsets": FIRST,
    "--eval-freq": ["128"],
    "--eval-episodes": ["1"],
    "--save-freq": ["128"],
    "--calibration-draws": ["1"],
    "--num-cpus": ["1"],
    "--count": ["2"],
    "--instances": ["2"],
    "--generated-racks": ["1"],
    "--cross-instances": ["1"],
    "--rollouts": ["1"],
    "--rounds": ["1"],
}
# One env process, small PPO/TRPO rollouts, an evaluation (and a checkpoint) every 128 steps.
SMALL_TRAINING = (
    '{"n_envs": 1, "n_steps": 128, "batch_size": 64, "eval_freq": 128, "eval_episodes": 1, '
    '"checkpoint_freq": 128}'
)


@dataclass(frozen=True)
class Rule:
    pattern: str  # a regex the command (one `&&` part, comment dropped) must match in full
    kind: str  # install | suite | covered | server | run
    slow: bool = True
    add: tuple[str, ...] = ()  # flags appended to a `run` command (when not already there)
    needs: tuple[str, ...] = ()  # modules it imports that an extra may lack: skip without
    covered_by: str = ""  # `covered`: tests/<file>::<test>


RULES = [
    Rule(r"python3 -m venv \.venv", "install"),
    Rule(r"\. \.venv/bin/activate", "install"),
    Rule(r"pip install .*", "install"),
    Rule(r"python -m pytest", "suite"),
    Rule(r"drake-tooluse (ik|fk) .*", "run", slow=False),
    Rule(
        r"drake-tooluse train( .*)?",
        "run",
        add=("--hyperparams", SMALL_TRAINING, "--no-progress"),
    ),
    Rule(r"drake-tooluse (simulate|measure|measure-box|measure-shape|evaluate|demo) .*", "run"),
    Rule(r"drake-tooluse demo", "run"),
    Rule(r"drake-tooluse (trajectory|transfer) .*", "run", add=("--calibration-draws", "1")),
    Rule(r"drake-tooluse export-csv .*", "run"),
    Rule(r"drake-tooluse distill .*", "run", add=("--episodes", "1")),
    Rule(
        r"drake-tooluse sweep --algos .*",
        "run",
        add=("--num-cpus", "1", "--episodes", "1", "--hyperparams", SMALL_TRAINING),
    ),
    Rule(r"drake-tooluse sweep --resume .*", "run"),
    Rule(
        r"ray start --head .*|drake-tooluse sweep --address auto .*",
        "covered",
        covered_by="tests/learning/test_sweep.py::"
        "test_on_two_nodes_a_killed_worker_s_cell_continues_and_a_failed_cell_is_reported",
    ),
    Rule(r"tensorboard --logdir .*", "server"),
    Rule(
        r"python -m rl_zoo3\.train .*",
        "run",
        add=("-n", "256", "--hyperparams", "n_steps:128", "batch_size:64"),
        needs=("rl_zoo3",),
    ),
    Rule(r"python benchmarks/transfer_experiments\.py.*", "run", add=("--modes", "closed-loop")),
    Rule(r"python benchmarks/open_loop_variants\.py .*", "run", add=("--calibration-draws", "1")),
    Rule(
        r"(taskset -c 1 )?python benchmarks/env_throughput\.py.*",
        "run",
        add=("--steps", "100", "--rounds", "1"),
        needs=("gymnasium_robotics",),
    ),
    Rule(r"python benchmarks/env_fidelity\.py( --update-docs)?", "run", add=("--episodes", "1")),
    Rule(
        r"python benchmarks/env_memory\.py.*",
        "run",
        add=("--rebuilds", "2", "--warmup", "10", "--steps", "200"),
    ),
    Rule(r"python benchmarks/ik_closed_loop\.py( --update-docs)?", "run", add=("--grid", "2")),
    Rule(
        r"python benchmarks/vision_accuracy\.py( --update-docs)?",
        "run",
        add=("--lengths", "0.1", "--noise-seeds", "1"),
    ),
    Rule(
        r"python benchmarks/ik_vs_tracik\.py",
        "run",
        add=("--targets", "20", "--paths", "1", "--path-steps", "20", "--lengths", "0.175"),
        needs=("pytracik",),
    ),
    Rule(r"drake-tooluse --version", "run", slow=False),
    Rule(r"drake-tooluse tools (sample|gallery|import) .*", "run"),
    Rule(r"python benchmarks/mesh_collision\.py.*", "run", add=("--points", "2000")),
    Rule(r"drake-tooluse record-video .*", "run", add=("--every", "10")),
    Rule(r"drake-tooluse study( --update-docs)? --status", "run"),
    Rule(
        r"drake-tooluse study( .*)?",
        "covered",
        covered_by="tests/faults/test_paper_study_runner.py",
    ),
    Rule(r"drake-tooluse study-report( .*)?", "run", needs=("rliable",)),
    Rule(r"python benchmarks/hook_vision_accuracy\.py.*", "run"),
    Rule(r"python benchmarks/pull_scripted\.py.*", "run"),
    Rule(
        r"python benchmarks/pull_policy\.py.*",
        "run",
        add=("--instances", "2", "--cross-instances", "1"),
    ),
    Rule(r"drake-tooluse choose-tool .*", "run", add=("--rollouts", "1")),
    Rule(r"python benchmarks/tool_choice\.py.*", "run", add=("--rollouts", "1")),
    Rule(r"python benchmarks/env_sanity\.py.*", "run", add=("--steps", "100")),
    Rule(
        r"python benchmarks/push_policies_hold\.py.*",
        "run",
        add=("--episodes", "1", "--runs", "1", "--tools", "0.175"),
    ),
    Rule(r"python benchmarks/distill_gap\.py .*", "run", add=("--episodes", "1", "--delays", "0")),
    Rule(
        r"python -m sphinx .*",
        "covered",
        covered_by="tests/docs/test_docs_site.py::test_push_outcome_ports_render",
    ),
]


@dataclass(frozen=True)
class Command:
    doc: str  # file name relative to the checkout
    block: int  # the fenced block's index in its file
    text: str  # one `&&` part of a line, comment dropped
    rule: Rule | None


def _lines(text: str):
    for block, body in enumerate(re.findall(r"```bash\n(.*?)```", text, flags=re.S)):
        for line in body.replace("\\\n", " ").splitlines():
            # A `#` after whitespace starts a comment (none of the lines quotes one).
            line = re.split(r"(?:^|\s)#", line, maxsplit=1)[0].strip()
            if line:
                yield block, line


def _rule(command: str) -> Rule | None:
    return next((r for r in RULES if re.fullmatch(r.pattern, command)), None)


def commands() -> list[Command]:
    found = []
    for doc in DOCS:
        for block, line in _lines(doc.read_text()):
            for part in line.split("&&"):
                text = " ".join(part.split())
                found.append(Command(str(doc.relative_to(ROOT)), block, text, _rule(text)))
    return found


COMMANDS = commands()
BLOCKS = sorted({(c.doc, c.block) for c in COMMANDS if c.rule and c.rule.kind in ("run", "server")})


def test_every_command_line_in_the_docs_has_a_rule():
    assert len(COMMANDS) > 40
    missing = [f"{c.doc}: {c.text}" for c in COMMANDS if c.rule is None]
    assert not missing, "no rule says how to run:\n" + "\n".join(missing)


def test_what_the_install_lines_name_exists():
    extras = PYPROJECT["project"]["optional-dependencies"]
    torch = next(d for d in PYPROJECT["project"]["dependencies"] if d.startswith("torch"))
    for c in COMMANDS:
        if c.rule is None or c.rule.kind != "install" or not c.text.startswith("pip install"):
            continue
        words = shlex.split(c.text)[2:]
        for word in words:
            named = re.fullmatch(r"(?:-e )?\.?\[([\w,]+)\]", word) or re.fullmatch(
                r"\.\[([\w,]+)\]", word
            )
            if named:
                assert set(named.group(1).split(",")) <= set(extras), (c.doc, c.text)
            elif word.startswith("torch"):
                assert word == torch, (c.doc, c.text, torch)
        if "--index-url" in words:
            assert words[words.index("--index-url") + 1] == "https://download.pytorch.org/whl/cpu"


def test_the_covered_lines_name_tests_that_exist():
    for c in COMMANDS:
        if c.rule is not None and c.rule.kind == "covered":
            file, _, name = c.rule.covered_by.partition("::")
            path = ROOT / file
            assert path.is_file(), c.rule.covered_by
            assert not name or f"def {name}(" in path.read_text(), c.rule.covered_by


def test_the_readme_test_line_is_what_ci_runs():
    readme = (ROOT / "README.md").read_text()
    line = 'python3 -m venv .venv && . .venv/bin/activate && pip install -e ".[test]" && python -m pytest'
    assert f"```bash\n{line}\n```" in readme
    assert line in (ROOT / ".ci" / "run").read_text()


# -- running them --------------------------------------------------------------------------


def _budgeted(argv: list[str], rule: Rule) -> list[str]:
    budgets = BUDGETS
    out, i = [], 0
    while i < len(argv):
        out.append(argv[i])
        if argv[i] in budgets:
            given = []
            i += 1
            while i < len(argv) and not argv[i].startswith("--"):
                given.append(argv[i])  # the flag's own values
                i += 1
            out += given[:1] if budgets[out[-1]] is FIRST else budgets[out[-1]]
            continue
        i += 1
    given = set(out)
    for k, flag in enumerate(rule.add):
        if not flag.startswith("-") or flag in given:
            continue  # a value, or a flag the command gives itself
        values = itertools.takewhile(lambda w: not w.startswith("-"), rule.add[k + 1 :])
        out += [flag, *values]
    return out


def _argv(text: str, rule: Rule, sandbox: Path) -> list[str]:
    argv = _budgeted(shlex.split(text), rule)
    if argv[0] == "taskset":
        argv = argv[3:] if shutil.which("taskset") is None else argv
    head = next((k for k, a in enumerate(argv) if a in ("python", "drake-tooluse")), None)
    if head is None:  # another program of the environment (tensorboard): the venv's
        beside = Path(sys.executable).parent / argv[0]
        argv[0] = str(beside) if beside.exists() else argv[0]
    elif argv[head] == "python":
        argv[head] = sys.executable
    else:
        argv[head : head + 1] = [sys.executable, "-m", "drake_tooluse.cli"]
    for k, word in enumerate(argv):  # inputs the sandbox does not copy: the checkout's
        if "/" in word and not word.startswith(("/", "runs/", "-")):
            if not (sandbox / word).exists() and (ROOT / word).exists():
                argv[k] = str(ROOT / word)
    return argv


WRITES = ("--out", "-f", "--record", "--save-images")  # flags whose value a command writes


def _paths(text: str) -> tuple[set[str], set[str]]:
    """The runs/ paths a command reads and those it writes."""
    words = shlex.split(text)
    reads, writes = set(), set()
    for k, word in enumerate(words):
        if word.startswith("runs/"):
            (writes if k > 0 and words[k - 1] in WRITES else reads).add(word)
    return reads, writes


def _needs(doc: str, block: int) -> list[int]:
    """The earlier blocks of `doc` that write what `block` reads and does not write itself."""
    ours = [c for c in COMMANDS if (c.doc, c.block) == (doc, block)]
    reads = set().union(*(_paths(c.text)[0] for c in ours)) - set().union(
        *(_paths(c.text)[1] for c in ours)
    )
    return sorted(
        {
            c.block
            for c in COMMANDS
            if c.doc == doc
            and c.block < block
            and any(r.startswith(w) for r in reads for w in _paths(c.text)[1])
        }
    )


@pytest.fixture(scope="module")
def sandboxes(tmp_path_factory):
    """doc -> (its scratch directory, the blocks run in it)."""
    made = {}

    def sandbox(doc: str) -> tuple[Path, set]:
        if doc not in made:
            path = tmp_path_factory.mktemp(Path(doc).stem)
            shutil.copytree(ROOT / "benchmarks", path / "benchmarks")
            shutil.copytree(ROOT / "docs", path / "docs")
            # `--update-docs` commands check that they run in a checkout's root.
            shutil.copy(ROOT / "pyproject.toml", path / "pyproject.toml")
            made[doc] = path, set()
        return made[doc]

    return sandbox


def _run(argv: list[str], cwd: Path) -> None:
    env = {
        **os.environ,
        "CUDA_VISIBLE_DEVICES": "",
        "PYTHONPATH": os.pathsep.join(
            p for p in (str(ROOT), os.environ.get("PYTHONPATH", "")) if p
        ),
    }
    # stdin at end-of-input: `--meshcat` waits for a line or its end before it closes the view.
    done = subprocess.run(
        argv,
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=TIMEOUT_S,
        env=env,
        stdin=subprocess.DEVNULL,
    )
    assert done.returncode == 0, (
        f"{shlex.join(argv)} (in {cwd}) exited {done.returncode}:\n"
        f"{done.stdout[-2000:]}\n{done.stderr[-3000:]}"
    )


def _serve(argv: list[str], cwd: Path) -> None:
    """Starts a server, waits until it says where it serves (60 s at most), stops it."""
    log = cwd / f"server-{time.monotonic_ns()}.log"
    with open(log, "w") as out:
        process = subprocess.Popen(
            argv, cwd=cwd, stdout=out, stderr=subprocess.STDOUT, start_new_session=True
        )
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and "http://" not in log.read_text():
            assert process.poll() is None, log.read_text()
            time.sleep(0.5)
        assert "http://" in log.read_text(), log.read_text()
    finally:
        os.killpg(process.pid, signal.SIGTERM)
        process.wait(timeout=30)


def _block_param(doc: str, block: int):
    parts = [c for c in COMMANDS if (c.doc, c.block) == (doc, block) and c.rule]
    slow = any(c.rule.slow for c in parts if c.rule.kind in ("run", "server"))
    return pytest.param(doc, block, id=f"{doc}:{block}", marks=[pytest.mark.slow] if slow else [])


def _run_block(doc: str, block: int, sandbox: Path, done: set) -> None:
    for earlier in _needs(doc, block):  # what it reads, written by an earlier block
        if earlier not in done:
            _run_block(doc, earlier, sandbox, done)
    for c in COMMANDS:
        if (c.doc, c.block) != (doc, block) or c.rule is None:
            continue
        if c.rule.kind not in ("run", "server"):
            continue
        for module in c.rule.needs:
            pytest.importorskip(module)
        argv = _argv(c.text, c.rule, sandbox)
        (_serve if c.rule.kind == "server" else _run)(argv, sandbox)
    done.add(block)


def test_a_block_that_reads_a_run_finds_the_block_that_writes_it():
    evaluate = next(c for c in COMMANDS if "evaluate --policy runs/ppo/best" in c.text)
    train = next(c for c in COMMANDS if c.doc == evaluate.doc and "--out runs/ppo" in c.text)
    assert _needs(evaluate.doc, evaluate.block) == [train.block]


@pytest.mark.parametrize("doc, block", [_block_param(*b) for b in BLOCKS])
def test_the_block_runs(doc, block, sandboxes):
    sandbox, done = sandboxes(doc)
    if block not in done:
        _run_block(doc, block, sandbox, done)
