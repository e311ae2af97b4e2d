"""Block diagrams of the runnable diagrams, written to `diagrams/` (Graphviz .dot + .svg).

The .dot text is deterministic (system ids renumbered), so a test can check that the committed
files are current without Graphviz; the .svg is rendered from it with Graphviz's `dot`.
"""

from __future__ import annotations

from pathlib import Path

from drake_tooluse.io import atomic_write_text


def _tip_control_diagram(diagrams_dir: Path):
    from drake_tooluse.scenario import load_scenario
    from drake_tooluse.scene import home_tip_pose
    from drake_tooluse.simulation import build_tip_control_diagram, tip_pose_trajectory

    scenario = load_scenario(diagrams_dir / "push.yaml")
    X = home_tip_pose(scenario)
    return build_tip_control_diagram(scenario, tip_pose_trajectory(X, [X], 1.0, 0.0)).diagram


def _policy_reality_diagram(diagrams_dir: Path):
    """The transfer's closed loop: the shipped policy in the reality (with its delay)."""
    from drake_tooluse.cli import TRANSFER_POLICY
    from drake_tooluse.policy import build_policy_diagram
    from drake_tooluse.scenario import load_scenario

    scenario = load_scenario(diagrams_dir / "reality.yaml")
    return build_policy_diagram(scenario, TRANSFER_POLICY, believed_tool_length=0.125).diagram


def _trajectory_reality_diagram(diagrams_dir: Path):
    """The transfer's open loop (the paper's): a tool-tip trajectory through the IK."""
    from drake_tooluse.scenario import load_scenario
    from drake_tooluse.scene import home_tip_pose
    from drake_tooluse.trajectory import TipTrajectory
    from drake_tooluse.transfer import build_trajectory_diagram

    scenario = load_scenario(diagrams_dir / "reality.yaml")
    X = home_tip_pose(scenario)
    traj = TipTrajectory([0.0], [X.translation()], [X.rotation().ToQuaternion().wxyz()])
    return build_trajectory_diagram(scenario, traj, believed_tool_length=0.125)[0]


# name -> builder of the diagram drawn as diagrams/<name>.dot/.svg
DIAGRAMS = {"tip_control": _tip_control_diagram, "policy_reality": _policy_reality_diagram,
            "trajectory_reality": _trajectory_reality_diagram}


def render_all(diagrams_dir: Path, check: bool = False) -> dict:
    from drake_tooluse.viz import graphviz_dot, render_svg

    out = {}
    for name, build in DIAGRAMS.items():
        dot_text = graphviz_dot(build(Path(diagrams_dir)))
        dot_path = Path(diagrams_dir) / f"{name}.dot"
        if check:
            if not dot_path.is_file() or dot_path.read_text() != dot_text:
                raise ValueError(f"{dot_path} is out of date; run `drake-tooluse render-diagrams`")
            out[name] = {"current": True}
            continue
        atomic_write_text(dot_path, dot_text)
        svg = render_svg(dot_text, dot_path.with_suffix(".svg"))
        out[name] = {"dot": str(dot_path), "svg": str(svg)}
    return out
