"""Writes `upstream_fk.json`: the `right_gripper` pose of Rethink's upstream Baxter URDF at
random right-arm configurations, the reference that `test_model.py` holds our model to.

The upstream URDF ships in PyPI's `hpp-baxter` (no Collada meshes needed: the plant is built
without geometry). Run once, offline afterwards:

    pip download --no-deps hpp-baxter -d /tmp/hpp && cd /tmp/hpp && unzip -o -q *.whl
    python tests/robot/data/make_upstream_fk.py /tmp/hpp/cmeel.prefix/share/hpp-baxter/urdf/baxter.urdf
"""

import sys
from pathlib import Path

import numpy as np
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant

from drake_tooluse.files import atomic_write_json
from drake_tooluse.robot.baxter_model import Q_LOWER, Q_UPPER, RIGHT_ARM_JOINTS


def upstream_fk(urdf: str, configurations: np.ndarray) -> list[list[float]]:
    plant = MultibodyPlant(0.0)
    parser = Parser(plant)
    parser.package_map().Add("example-robot-data", str(Path(urdf).parent))
    text = Path(urdf).read_text()
    parser.AddModelsFromString(text, "urdf")
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base"))
    plant.Finalize()
    context = plant.CreateDefaultContext()
    frame = plant.GetFrameByName("right_gripper")
    poses = []
    for q in configurations:
        for name, angle in zip(RIGHT_ARM_JOINTS, q):
            plant.GetJointByName(name).set_angle(context, angle)
        poses.append(frame.CalcPoseInWorld(context).GetAsMatrix34().reshape(-1).tolist())
    return poses


def main(urdf: str) -> None:
    rng = np.random.default_rng(2024)
    qs = np.vstack([np.zeros(7), rng.uniform(Q_LOWER, Q_UPPER, size=(49, 7))])
    out = Path(__file__).with_name("upstream_fk.json")
    atomic_write_json(
        out,
        {
            "source": "hpp-baxter baxter.urdf (Rethink baxter_description)",
            "frame": "right_gripper in base",
            "q": qs.tolist(),
            "X_34_rowmajor": upstream_fk(urdf, qs),
        },
    )
    print(f"wrote {out}")


if __name__ == "__main__":
    main(sys.argv[1])
