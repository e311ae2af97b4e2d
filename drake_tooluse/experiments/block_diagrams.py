"""Block diagrams of the runnable diagrams, written to the scenario folder `diagrams/` (Graphviz
.dot + .svg).

The .dot text is deterministic (system ids renumbered), so a test can check that the committed
files are current without Graphviz; the .svg is rendered from it with Graphviz's `dot`. Each .dot
opens with a comment naming the Drake release that rendered it: on that release the check is
exact; on another (whose MultibodyPlant has other ports: 1.56 added two) it compares what the
project owns (`structure`): every system's class and name, the ports of the project's own
systems, and every connection by system and port name.
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

from drake_tooluse import compat
from drake_tooluse.builders.trajectory_diagram import build_trajectory_diagram
from drake_tooluse.files import atomic_write_text
from drake_tooluse.learning.policy_dir import load_policy
from drake_tooluse.paths import TRANSFER_POLICY
from drake_tooluse.robot.model import RobotBelief
from drake_tooluse.systems.tip_trajectory import waypoint_trajectory
from drake_tooluse.tasks.deploy import build_policy_diagram
from drake_tooluse.validation import EnvironmentProblem
from drake_tooluse.world.scenario import load_scenario
from drake_tooluse.world.scene import home_tip_pose

# The tool the reality's robot believes in, in the drawings (the demo's).
BELIEF = RobotBelief(0.125)


def _home_trajectory(scenario):
    X = home_tip_pose(scenario)
    return waypoint_trajectory(X, [X], 1.0, 0.0)


def _tip_control_diagram(scenarios_dir: Path):
    """The waypoint simulation: a tool-tip trajectory through the IK in the push world."""
    scenario = load_scenario(scenarios_dir / "push.yaml")
    return build_trajectory_diagram(scenario, _home_trajectory(scenario)).diagram


def _policy_reality_diagram(scenarios_dir: Path):
    """The transfer's closed loop: the shipped policy in the reality (with its delay)."""
    scenario = load_scenario(scenarios_dir / "reality.yaml")
    return build_policy_diagram(scenario, load_policy(TRANSFER_POLICY), BELIEF).diagram


def _trajectory_reality_diagram(scenarios_dir: Path):
    """The transfer's open loop (the paper's): a tool-tip trajectory through the IK."""
    scenario = load_scenario(scenarios_dir / "reality.yaml")
    return build_trajectory_diagram(
        scenario, _home_trajectory(scenario), BELIEF, lead=scenario.control.control_period
    ).diagram


# name -> builder of the diagram drawn as diagrams/<name>.dot/.svg
DIAGRAMS = {
    "tip_control": _tip_control_diagram,
    "policy_reality": _policy_reality_diagram,
    "trajectory_reality": _trajectory_reality_diagram,
}


def graphviz_dot(diagram, max_depth: int = 1) -> str:
    """The diagram's Graphviz text with Drake's run-dependent system ids renumbered, so the
    same diagram always gives the same text."""
    text = diagram.GetGraphvizString(max_depth=max_depth)
    ids: dict[str, str] = {}

    def renumber(match):
        return ids.setdefault(match.group(0), str(len(ids)))

    # Ids appear as `digraph _N`, `clusterN...` and node names `sN`.
    lines = re.sub(r"(?<=digraph _)\d+|(?<=cluster)\d+|(?<=\bs)\d+\b", renumber, text).split("\n")
    # Drake lists the edges in id order, which depends on the run: sort them.
    edge_rows = [i for i, line in enumerate(lines) if " -> " in line]
    for i, line in zip(edge_rows, sorted(lines[i] for i in edge_rows)):
        lines[i] = line
    return "\n".join(lines)


def render_svg(dot_text: str, svg_path: str | Path) -> Path:
    """Renders Graphviz text to SVG with the `dot` program (Debian package `graphviz`)."""
    dot = shutil.which("dot")
    if dot is None:
        raise EnvironmentProblem(
            "rendering a block diagram needs Graphviz's `dot` (apt-get install graphviz)"
        )
    svg = subprocess.run(
        [dot, "-Tsvg"], input=dot_text, capture_output=True, text=True, check=True
    ).stdout
    return atomic_write_text(svg_path, svg)


# The first line of each committed .dot.
_HEADER = "// rendered with drake "


def rendered_with(dot_file_text: str) -> str | None:
    """The Drake release named in a .dot file's first line, or None."""
    first = dot_file_text.split("\n", 1)[0]
    return first[len(_HEADER) :].strip() if first.startswith(_HEADER) else None


_NODE = re.compile(
    r"^(\w+) \[shape=none.*?<B>(.*?)</B><BR/>\s*name=(.*?)\s*</TD>(.*?)^>\];", re.S | re.M
)
_PORT = re.compile(r'<TD PORT="([uy])(\d+)"[^>]*>(.*?)</TD>', re.S)
_EDGE = re.compile(r"^(\w+):y(\d+):e -> (\w+):u(\d+):w$", re.M)


def structure(dot_text: str) -> dict:
    """What a diagram's Graphviz text says that does not depend on the Drake release: every
    system as (class, name); each of the project's own systems (a `drake_tooluse.` class) with
    its input and output port names; every connection as ((system, output port), (system,
    input port)). Drake's own systems' ports (the plant's grow with releases) are left out
    except where they are connected."""
    systems, own, ports = [], {}, {}
    for node, cls, name, body in _NODE.findall(dot_text):
        systems.append((cls, name))
        ports[node] = {"name": name}
        for kind, index, label in _PORT.findall(body):
            label = re.sub(r"<[^>]*>", "", label).strip()
            if label:
                ports[node][kind + index] = label
        if cls.startswith("drake_tooluse."):
            own[name] = {
                "inputs": [v for k, v in ports[node].items() if k.startswith("u")],
                "outputs": [v for k, v in ports[node].items() if k.startswith("y")],
            }

    def end(node, port):
        known = ports.get(node, {})
        return (known.get("name", node), known.get(port, port))

    connections = sorted(
        (end(a, "y" + i), end(b, "u" + j)) for a, i, b, j in _EDGE.findall(dot_text)
    )
    return {"systems": sorted(systems), "own": own, "connections": connections}


def render_all(scenarios_dir: Path, check: bool = False) -> dict:
    """Writes (or with `check`, compares) each diagram's .dot and .svg in `scenarios_dir`.
    A check is exact on the Drake release that rendered the files and compares `structure`
    on any other; it gives `{"current": True, "exact": ...}` per diagram."""
    out = {}
    for name, build in DIAGRAMS.items():
        dot_text = graphviz_dot(build(Path(scenarios_dir)))
        dot_path = Path(scenarios_dir) / f"{name}.dot"
        file_text = f"{_HEADER}{compat.DRAKE_VERSION}\n{dot_text}"
        if check:
            committed = dot_path.read_text() if dot_path.is_file() else ""
            exact = compat.reproduces_exactly(rendered_with(committed))
            if exact:
                current = committed == file_text
            else:
                current = rendered_with(committed) is not None and structure(
                    committed
                ) == structure(dot_text)
            if not current:
                raise ValueError(
                    f"{dot_path} is out of date; run `drake-tooluse dev render-diagrams`"
                )
            out[name] = {"current": True, "exact": exact}
            continue
        atomic_write_text(dot_path, file_text)
        svg = render_svg(file_text, dot_path.with_suffix(".svg"))
        out[name] = {"dot": str(dot_path), "svg": str(svg)}
    return out
