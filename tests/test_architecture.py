"""The package's layers (docs/ARCHITECTURE.md), checked on the source: no import cycle, no
import up the data flow, nothing in the library imports the command line, and no library
import of the package hidden inside a function."""

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "drake_tooluse"
# In data-flow order; a module may import from its own layer and the layers before it.
LAYERS = [
    {"paths", "limits", "validation", "files", "compat", "progress", "provenance"},
    {"perception"},
    {"robot"},
    {"world"},
    {"systems"},
    {"builders"},
    {"tasks"},
    {"learning"},
    {"experiments"},
    {"cli"},
]


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _imports(tree: ast.AST, module: str):
    """(imported drake_tooluse module, line, inside a function) for each import in `tree`."""
    functions = [
        n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))
    ]
    in_function = {id(sub) for f in functions for sub in ast.walk(f)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            assert not node.level, f"{module} line {node.lineno}: use absolute imports"
            names = [node.module] + [f"{node.module}.{a.name}" for a in node.names]
        else:
            continue
        for name in names:
            if name == "drake_tooluse" or name.startswith("drake_tooluse."):
                yield name, node.lineno, id(node) in in_function


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _known(name: str) -> str | None:
    """The package module an imported name refers to (a module, or a name in one)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _graph() -> dict:
    graph = {}
    for module, path in MODULES.items():
        tree = ast.parse(path.read_text())
        graph[module] = {
            (_known(n), line, inside)
            for n, line, inside in _imports(tree, module)
            if _known(n) not in (None, module)
        }
    return graph


def _layer(module: str) -> int:
    parts = module.split(".")
    if len(parts) == 1:
        return -1  # the package itself: the public surface, above the layers
    for i, names in enumerate(LAYERS):
        if parts[1] in names:
            return i
    raise AssertionError(f"{module} is in no layer: add it to LAYERS and docs/ARCHITECTURE.md")


GRAPH = _graph()


def test_every_module_is_in_a_layer():
    for module in MODULES:
        _layer(module)


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_upward_import(module):
    here = _layer(module)
    upward = [
        f"line {line}: {target} (layer {LAYERS[_layer(target)]})"
        for target, line, _ in GRAPH[module]
        if here >= 0 and _layer(target) > here
    ]
    assert not upward, f"{module} (layer {LAYERS[here]}) imports up the data flow: {upward}"


def test_nothing_outside_the_cli_imports_it():
    offenders = [
        f"{m} line {line}"
        for m, edges in GRAPH.items()
        if _layer(m) != len(LAYERS) - 1
        for target, line, _ in edges
        if _layer(target) == len(LAYERS) - 1
    ]
    assert not offenders, f"the command line is a leaf; imported by {offenders}"


def test_library_imports_of_the_package_are_at_module_level():
    """Imports inside functions hide the graph; only the command line defers its imports (so
    that `--help` and argument errors come before Drake and torch load)."""
    hidden = [
        f"{m} line {line}: {target}"
        for m, edges in GRAPH.items()
        if _layer(m) != len(LAYERS) - 1
        for target, line, inside in edges
        if inside
    ]
    assert not hidden, f"imports inside functions: {hidden}"


def test_no_import_cycle():
    edges = {m: {t for t, _, _ in e} for m, e in GRAPH.items()}
    state, stack = {}, []

    def visit(m):
        state[m] = "open"
        stack.append(m)
        for t in sorted(edges[m]):
            if state.get(t) == "open":
                cycle = stack[stack.index(t) :] + [t]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if t not in state:
                visit(t)
        stack.pop()
        state[m] = "done"

    for m in sorted(edges):
        if m not in state:
            visit(m)


def _is_task(module: str) -> bool:
    """A module of a task package (`drake_tooluse.tasks.<task>…`, a subpackage), not one of
    what every task shares (`tasks.contract`, `tasks.sanity`: modules of `tasks` itself)."""
    parts = module.split(".")
    return len(parts) >= 3 and parts[1] == "tasks" and (PACKAGE / "tasks" / parts[2]).is_dir()


# Layers that may import a task: the experiments, the command line, the tasks themselves and
# the package's top level (which registers every task's env ids).
TASK_USERS = {"experiments", "cli", "tasks"}


def _task_imports(graph) -> list[str]:
    return [
        f"{m} line {line}: {target}"
        for m, edges in graph.items()
        if len(m.split(".")) > 1 and m.split(".")[1] not in TASK_USERS
        for target, line, _ in edges
        if _is_task(target)
    ]


def test_nothing_below_the_experiments_imports_a_task():
    """learning/ and every layer under it reach tasks through Gymnasium's registry and the task
    contract only, so a new task is a package of its own."""
    offenders = _task_imports(GRAPH)
    assert not offenders, f"task imports below experiments/: {offenders}"


def test_tasks_do_not_import_each_other():
    crossing = [
        f"{m} line {line}: {target}"
        for m, edges in GRAPH.items()
        if _is_task(m)
        for target, line, _ in edges
        if _is_task(target) and target.split(".")[2] != m.split(".")[2]
    ]
    assert not crossing, f"a task imports another task: {crossing}"


def test_the_checker_sees_a_planted_task_import():
    tree = ast.parse("from drake_tooluse.tasks.push.env import ToolPushEnv\n")
    edges = {(_known(n), 1, False) for n, _, _ in _imports(tree, "drake_tooluse.learning.x")}
    assert _task_imports({"drake_tooluse.learning.x": edges})
    assert not _task_imports({"drake_tooluse.experiments.x": edges})


def test_the_checker_sees_a_planted_upward_import(tmp_path):
    """The checks above can fail: an upward import written into a module is found."""
    tree = ast.parse("from drake_tooluse.learning.train import train\n")
    found = [_known(n) for n, _, _ in _imports(tree, "drake_tooluse.world.scene")]
    assert "drake_tooluse.learning.train" in found
    assert _layer("drake_tooluse.learning.train") > _layer("drake_tooluse.world.scene")


def _private_imports(tree: ast.AST, module: str) -> list[str]:
    """`from drake_tooluse.x import _name` in `tree`: another module's private name (a dunder
    such as `__version__` is public)."""
    return [
        f"{module} line {node.lineno}: {node.module}.{alias.name}"
        for node in ast.walk(tree)
        if isinstance(node, ast.ImportFrom) and _known(node.module or "")
        for alias in node.names
        if alias.name.startswith("_") and not alias.name.endswith("__")
    ]


def test_no_module_imports_another_modules_private_names():
    """What two modules share is public in one of them (named for what it does), so a
    module's private names stay free to change."""
    found = [
        line
        for module, path in MODULES.items()
        for line in _private_imports(ast.parse(path.read_text()), module)
    ]
    assert not found, f"private names imported from another module: {found}"


def test_the_checker_sees_a_planted_private_import():
    tree = ast.parse("from drake_tooluse.perception.markers import _blob, __doc__, find_blobs\n")
    assert _private_imports(tree, "drake_tooluse.perception.hook") == [
        "drake_tooluse.perception.hook line 1: drake_tooluse.perception.markers._blob"
    ]


# The task names the tool-choice tasks declare (`tasks.contract.ToolTask`).
TASK_NAMES = {"push", "push-far", "pull"}


def _task_name_tests(tree) -> list[int]:
    """Lines of `tree` that compare with a task's name or key a table by one."""
    lines = []
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Compare):
            names = [node.left, *node.comparators]
        elif isinstance(node, ast.Dict):
            names = [k for k in node.keys if k is not None]
        if any(isinstance(n, ast.Constant) and n.value in TASK_NAMES for n in names):
            lines.append(node.lineno)
    return lines


def test_no_module_of_experiments_or_cli_tells_the_tasks_apart_by_name():
    found = {}
    for layer in ("experiments", "cli"):
        for path in sorted((PACKAGE / layer).glob("*.py")):
            name = str(path.relative_to(PACKAGE.parent))
            lines = _task_name_tests(ast.parse(path.read_text()))
            if lines:
                found[name] = lines
    assert not found, f"a test of a task's name or a table by task: {found}"


def test_the_task_name_check_sees_a_planted_test():
    tree = ast.parse('if task == "pull":\n    pass\nTABLE = {"push": 1}\n')
    assert _task_name_tests(tree) == [1, 3]
