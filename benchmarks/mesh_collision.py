"""Collision geometry of a concave tool from its mesh: Drake's convex hull (what Drake offers:
a `Convex`, and its point contact's view of any `Mesh`) beside CoACD's convex decomposition
(`drake-tooluse tools import`), on generated hooks, arcs and rakes.

    python benchmarks/mesh_collision.py [--seeds 3] [--points 20000] [--out FILE]

For each tool: the parts, the seconds CoACD took, the collision geometry's volume over the
mesh's, and how much of the tool's concavity (the points inside the mesh's hull but outside the
mesh: where a hooked object sits) each collision geometry fills. A hook can only hook what its
collision geometry leaves free. Prints a Markdown table; writes JSON (default
runs/mesh_collision-<time>/mesh_collision.json).
"""

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import trimesh

from drake_tooluse.cli.common import run_script
from drake_tooluse.experiments.runs import BenchmarkOutput
from drake_tooluse.files import atomic_write_json
from drake_tooluse.robot.mesh_import import convex_parts, import_mesh_tool
from drake_tooluse.robot.tool_files import write_tool_files
from drake_tooluse.robot.tool_generator import generate_tool
from drake_tooluse.validation import check_int

OUTPUT = BenchmarkOutput(Path(__file__))
FAMILIES = ("hook", "arc", "rake")


def inside_any(convex_meshes, points: np.ndarray) -> np.ndarray:
    """Whether each point is inside any of the convex meshes (behind every face's plane): the
    hull, CoACD's parts and the generated tools' pieces (cylinders) are all convex."""
    inside = np.zeros(len(points), bool)
    for mesh in convex_meshes:
        n = mesh.face_normals
        offsets = np.einsum("ij,ij->i", n, mesh.triangles[:, 0])
        inside |= np.all(points @ n.T <= offsets + 1e-12, axis=1)
    return inside


def measure(family: str, seed: int, points: int, work: Path) -> dict:
    """One generated tool written as OBJ, imported with CoACD, and its concavity sampled."""
    tool = generate_tool(family, seed).tool
    files = write_tool_files(tool, work / "tool")
    imported = import_mesh_tool(files["obj"], files["sidecar"], work / "imported", "coacd")
    mesh = trimesh.load(files["obj"], force="mesh", process=False)
    pieces = mesh.split(only_watertight=True)  # the closed pieces, which overlap
    hull = convex_parts(mesh, "hull")[0]
    parts = [
        trimesh.load(p, force="mesh") for p in sorted((work / "imported").glob("collision_*.obj"))
    ]
    rng = np.random.default_rng(seed)
    lo, hi = hull.bounds
    sample = rng.uniform(lo, hi, (points, 3))
    concave = inside_any([hull], sample) & ~inside_any(pieces, sample)
    filled = inside_any(parts, sample[concave])
    return {
        "tool": f"{family} s{seed}",
        "parts": imported["parts"],
        "coacd_s": imported["decomposition_s"],
        "coacd_volume_ratio": imported["parts_volume_m3"] / imported["volume_m3"],
        "hull_volume_ratio": hull.volume / imported["volume_m3"],
        "concavity_points": int(concave.sum()),
        "concavity_filled_by_coacd": float(filled.mean()) if concave.any() else None,
        "concavity_filled_by_hull": 1.0,  # the concavity is inside the hull by definition
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="tools per family (seeds 0 …)")
    ap.add_argument("--points", type=int, default=20_000, help="samples in each hull's box")
    OUTPUT.add_arguments(ap)
    args = ap.parse_args()
    try:
        check_int(args.seeds, 1, 100, "--seeds")
        check_int(args.points, 100, 10_000_000, "--points")
    except ValueError as e:
        ap.error(str(e))
    out = OUTPUT.path(args)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for family in FAMILIES:
            for seed in range(args.seeds):
                work = Path(tmp) / f"{family}-{seed}"
                work.mkdir()
                rows.append(measure(family, seed, args.points, work))
    print(
        "| tool | CoACD parts | CoACD s | volume / mesh: CoACD | volume / mesh: hull | concavity filled: CoACD | concavity filled: hull |"
    )
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        filled = r["concavity_filled_by_coacd"]
        print(
            f"| {r['tool']} | {r['parts']} | {r['coacd_s']:.1f} | {r['coacd_volume_ratio']:.2f} | "
            f"{r['hull_volume_ratio']:.2f} | {'—' if filled is None else f'{filled:.0%}'} | 100 % |"
        )
    atomic_write_json(out, {"rows": rows, "points": args.points})
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(run_script(main))
