"""The committed block diagrams are current."""

from drake_tooluse.experiments.block_diagrams import DIAGRAMS, render_all
from drake_tooluse.paths import SCENARIOS_DIR as DIAGRAMS_DIR


def test_committed_block_diagrams_are_current():
    assert render_all(DIAGRAMS_DIR, check=True) == {name: {"current": True} for name in DIAGRAMS}
    for name in DIAGRAMS:
        svg = (DIAGRAMS_DIR / f"{name}.svg").read_text()
        assert "<svg" in svg and "ToolTipIKSystem" in svg
