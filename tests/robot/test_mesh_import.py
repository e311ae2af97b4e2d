"""A tool from a mesh (`robot.mesh_import`, `drake-tooluse tools import`): the mesh as its visual,
convex parts as its collision geometry, its inertia from the closed mesh, its frames from the
sidecar; an SDF that reads back and that the push env holds."""

import gymnasium as gym
import numpy as np
import pytest
import yaml
from gymnasium.utils.env_checker import check_env

from drake_tooluse.cli import main
from drake_tooluse.paths import DEFAULT_SCENARIO
from drake_tooluse.robot.mesh_import import import_mesh_tool, read_sidecar
from drake_tooluse.robot.model import load_tool_model, tool_spatial_inertia
from drake_tooluse.robot.tool import MeshShape
from drake_tooluse.robot.tool_files import write_tool_files
from drake_tooluse.robot.tool_generator import DENSITY, generate_tool


@pytest.fixture(scope="module")
def hook_files(tmp_path_factory):
    """A generated hook written as OBJ, and the sidecar of its frames written beside it."""
    work = tmp_path_factory.mktemp("hook")
    tool = generate_tool("hook", 0).tool
    files = write_tool_files(tool, work / "tool")
    return tool, files["obj"], files["sidecar"]


def test_a_mesh_tool_reads_back_with_its_frames_inertia_and_hull(hook_files, tmp_path):
    tool, obj, sidecar = hook_files
    out = import_mesh_tool(obj, sidecar, tmp_path / "t", collision="hull")
    assert out["parts"] == 1 and out["collision"] == "hull"
    back = load_tool_model(out["sdf"])
    assert set(back.frames()) == set(tool.frames())
    for name, X in tool.frames().items():
        np.testing.assert_allclose(back.frames()[name].translation, X.translation, atol=1e-9)
    (visual,) = back.pieces()
    assert isinstance(visual.shape, MeshShape) and not visual.shape.convex
    assert all(p.shape.convex for p in back.collision_pieces())
    # Solid PLA over the closed mesh: the generator's mass of the same pieces, to the facets.
    assert back.mass == pytest.approx(
        DENSITY * sum(p.shape.volume() for p in tool.pieces()), rel=0.02
    )
    com = tool_spatial_inertia(back).get_com()
    np.testing.assert_allclose(com, tool_spatial_inertia(tool).get_com(), atol=2e-3)


@pytest.mark.slow  # ~2 s: an env built; .ci/run runs it
def test_the_push_env_holds_a_mesh_tool(hook_files, tmp_path):
    _, obj, sidecar = hook_files
    out = import_mesh_tool(obj, sidecar, tmp_path / "t", collision="hull")
    scenario = tmp_path / "held.yaml"
    scenario.write_text(f"base: {DEFAULT_SCENARIO}\ntool: {{model: {out['sdf']}}}\n")
    env = gym.make("drake_tooluse/ToolPush-v1", scenario=str(scenario))
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.slow  # ~4 s: CoACD on a hook; .ci/run runs it
def test_coacd_splits_a_hook_into_convex_parts_that_leave_its_bend_free(hook_files, tmp_path):
    _, obj, sidecar = hook_files
    coacd = import_mesh_tool(obj, sidecar, tmp_path / "c", collision="coacd")
    hull = import_mesh_tool(obj, sidecar, tmp_path / "h", collision="hull")
    assert coacd["parts"] >= 2
    # The parts follow the hook; the hull fills its bend.
    assert coacd["parts_volume_m3"] < 0.75 * hull["parts_volume_m3"]
    assert len(load_tool_model(coacd["sdf"]).collision_pieces()) == coacd["parts"]


@pytest.mark.parametrize(
    "sidecar, match",
    [
        ({"frames": {"corner": [0, 0, 0.1]}}, "'tool_tip' frame"),
        ({"frames": {"tool_tip": [0, 0, 0.1]}, "colour": "red"}, "a mapping of"),
        ({"frames": {"tool_tip": [0, 0, "x"]}}, "frames.tool_tip"),
        ({"frames": {"tool_tip": [0, 0, 0.1]}, "mass": -1}, "mass=-1"),
        ({"frames": {"tool_tip": [0, 0, 0.1], "grasp": [0, 0, 0]}}, "give the grasp as"),
    ],
)
def test_a_bad_sidecar_is_refused_naming_the_file_and_field(sidecar, match, tmp_path):
    path = tmp_path / "sidecar.yaml"
    path.write_text(yaml.safe_dump(sidecar))
    with pytest.raises(ValueError, match=match):
        read_sidecar(path)


def test_an_open_mesh_is_refused(hook_files, tmp_path):
    _, _, sidecar = hook_files
    open_mesh = tmp_path / "open.obj"
    open_mesh.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(ValueError, match="not closed"):
        import_mesh_tool(open_mesh, sidecar, tmp_path / "t", collision="hull")
    assert not (tmp_path / "t").exists()


def test_tools_import_refuses_bad_input_before_any_work(hook_files, tmp_path, capsys):
    _, obj, sidecar = hook_files
    base = ["tools", "import", "--mesh", str(obj), "--sidecar", str(sidecar)]
    for argv, match in [
        (["--collision", "vhacd", "--out", str(tmp_path / "a")], "unknown collision 'vhacd'"),
        (["--out", str(tmp_path / "b"), "--mesh", str(tmp_path / "none.obj")], "is not a file"),
    ]:
        assert main([*base, *argv]) == 2
        assert match in capsys.readouterr().err
    assert not any(tmp_path.iterdir())
    assert main([*base, "--collision", "hull", "--out", str(tmp_path / "ok")]) == 0
    assert "1 convex collision part(s) by hull" in capsys.readouterr().out
