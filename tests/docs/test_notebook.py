"""notebooks/getting_started.ipynb runs from top to bottom on a kernel of this Python.

Running it needs the `docs` extra (nbclient, nbformat, ipykernel) and is slow: it measures a
tool, solves IK and runs the shipped policy for a whole push (22–60 s here, by the load on the
machine). That it is committed without outputs is checked in the default suite.
"""

import json
import re
import sys
import time
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[2] / "notebooks" / "getting_started.ipynb"
KERNEL = "drake-tooluse-test"


@pytest.fixture
def kernel_of_this_python(tmp_path, monkeypatch) -> str:
    """A kernelspec that starts this interpreter (not whichever `python` is first on PATH)."""
    spec = tmp_path / "jupyter" / "kernels" / KERNEL
    spec.mkdir(parents=True)
    argv = [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"]
    (spec / "kernel.json").write_text(
        json.dumps({"argv": argv, "display_name": KERNEL, "language": "python"})
    )
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    return KERNEL


def test_committed_without_outputs():
    notebook = json.loads(NOTEBOOK.read_text())
    code = [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]
    assert code
    for cell in code:
        assert not cell["outputs"] and cell["execution_count"] is None, (
            "clear the notebook's outputs before committing it"
        )


@pytest.mark.slow
def test_notebook_runs(kernel_of_this_python, tmp_path):
    import nbformat
    from nbclient import NotebookClient

    notebook = nbformat.read(NOTEBOOK, as_version=4)
    client = NotebookClient(
        notebook,
        kernel_name=kernel_of_this_python,
        timeout=600,  # per cell
        resources={"metadata": {"path": str(tmp_path)}},  # it writes nothing; run it elsewhere
    )
    start = time.perf_counter()
    client.execute()  # raises CellExecutionError naming the cell that failed
    print(f"notebook ran in {time.perf_counter() - start:.1f} s")
    text = "\n".join(
        output.get("text", "")
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.outputs
        if output.output_type == "stream"
    )
    images = [
        output
        for cell in notebook.cells
        if cell.cell_type == "code"
        for output in cell.outputs
        if "image/png" in output.get("data", {})
    ]
    assert "Meshcat: http://" in text
    measured_mm = float(re.search(r"measured ([0-9.]+) mm \(truth 150 mm", text).group(1))
    assert abs(measured_mm - 150) < 3, text  # the measurement guide's bound
    assert "solved: True" in text
    assert "success: True" in text, text  # the shipped policy pushes the box to the goal
    assert len(images) == 2  # the camera view and the push from above
