"""The committed block diagrams are current: exactly on the Drake release that rendered them
(named in each .dot's first line), in what the project owns on any other."""

import pytest

from drake_tooluse import compat
from drake_tooluse.experiments.block_diagrams import (
    DIAGRAMS,
    render_all,
    rendered_with,
    structure,
)
from drake_tooluse.paths import SCENARIOS_DIR as DIAGRAMS_DIR


def test_committed_block_diagrams_are_current():
    exact = {
        name: compat.reproduces_exactly(rendered_with((DIAGRAMS_DIR / f"{name}.dot").read_text()))
        for name in DIAGRAMS
    }
    assert render_all(DIAGRAMS_DIR, check=True) == {
        name: {"current": True, "exact": exact[name]} for name in DIAGRAMS
    }
    for name in DIAGRAMS:
        assert rendered_with((DIAGRAMS_DIR / f"{name}.dot").read_text()) is not None
        svg = (DIAGRAMS_DIR / f"{name}.svg").read_text()
        assert "<svg" in svg and "ToolTipIKSystem" in svg


def test_committed_block_diagrams_name_one_release():
    """The three were rendered together."""
    releases = {rendered_with((DIAGRAMS_DIR / f"{name}.dot").read_text()) for name in DIAGRAMS}
    assert len(releases) == 1 and compat.drake_version(releases.pop()) >= (1, 51)


# A diagram's text with a Drake system (with a port a newer release adds) and one of ours.
DOT = """// rendered with drake 1.51.1
digraph _0 {
s1 [shape=none, border=0, label=<
<TABLE BORDER="0" CELLSPACING="0">
<TR><TD BORDER="1" COLSPAN="2">
<B>MultibodyPlant</B><BR/>
name=plant
</TD></TR>
<TR>
<TD PORT="u0" BORDER="1" >actuation</TD>
<TD PORT="y0" BORDER="1" >state</TD>
</TR>
<TR>
<TD PORT="u1" BORDER="1" COLOR="grey" ROWSPAN="1" SIDES="BL"></TD>
<TD PORT="y1" BORDER="1" ><FONT COLOR="grey">body_poses</FONT></TD>
</TR>
</TABLE>
>];
s2 [shape=none, border=0, label=<
<TABLE BORDER="0" CELLSPACING="0">
<TR><TD BORDER="1" COLSPAN="2">
<B>drake_tooluse.systems.tool_tip_ik.ToolTipIKSystem</B><BR/>
name=tool_tip_ik
</TD></TR>
<TR>
<TD PORT="u0" BORDER="1" >arm_state</TD>
<TD PORT="y0" BORDER="1" >desired_state</TD>
</TR>
</TABLE>
>];
s1:y0:e -> s2:u0:w
s2:y0:e -> s1:u0:w
}
"""


def test_structure_reads_systems_ports_and_connections():
    assert rendered_with(DOT) == "1.51.1" and rendered_with(DOT.split("\n", 1)[1]) is None
    assert structure(DOT) == {
        "systems": [
            ("MultibodyPlant", "plant"),
            ("drake_tooluse.systems.tool_tip_ik.ToolTipIKSystem", "tool_tip_ik"),
        ],
        "own": {"tool_tip_ik": {"inputs": ["arm_state"], "outputs": ["desired_state"]}},
        "connections": [
            (("plant", "state"), ("tool_tip_ik", "arm_state")),
            (("tool_tip_ik", "desired_state"), ("plant", "actuation")),
        ],
    }


def test_structure_ignores_a_port_a_drake_release_adds_to_the_plant():
    # As 1.56 did: a new plant input before the padding cell, the connected ports renumbered.
    newer = DOT.replace(
        '<TD PORT="u1" BORDER="1" COLOR="grey"', '<TD PORT="u1" BORDER="1" >surface_speeds</TD>\n'
    ).replace('<TD PORT="u0" BORDER="1" >actuation', '<TD PORT="u9" BORDER="1" >actuation')
    newer = newer.replace("s2:y0:e -> s1:u0:w", "s2:y0:e -> s1:u9:w")
    assert newer != DOT and structure(newer) == structure(DOT)


@pytest.mark.parametrize(
    "change",
    [
        ("name=tool_tip_ik", "name=ik"),  # a system renamed
        (">arm_state<", ">q_measured<"),  # a port of ours renamed
        ("s1:y0:e -> s2:u0:w", "s1:y1:e -> s2:u0:w"),  # connected to another plant port
        ("s2:y0:e -> s1:u0:w\n", ""),  # a connection dropped
    ],
)
def test_structure_sees_a_change_of_ours(change):
    assert structure(DOT.replace(*change)) != structure(DOT)
