"""Fitting the generator's families to a cloud (`robot.tool_fit`) without a camera: clouds
sampled on a generated tool's surface, held shifted in the hand, give back its family and its
working frames in G; a cloud of no family is "other"; too small a cloud is refused."""

import numpy as np
import pytest

from drake_tooluse.perception.tool_shape import Z_MIN_G
from drake_tooluse.robot.tool_fit import (
    OTHER,
    FamilyFit,
    fit_family,
    measure_shape_from_points,
    signed_distance,
)
from drake_tooluse.robot.tool_generator import FAMILIES, generate_tool


def surface_cloud(generated, across, along, seed=0, noise=0.0003, spacing=0.003):
    """Points on the surface of `generated`'s solid (the union of its segments' flat-capped
    cylinders: sides and end discs) in
    G, held (across, along) m off the nominal grasp, beyond the fingertips, with noise."""
    rng = np.random.default_rng(seed)
    skeleton = FAMILIES[generated.family].skeleton(generated.params)
    r = generated.params["radius"]
    A, B = skeleton.end_points()
    offset = np.array([across, 0.0, along])
    A, B = A + offset, B + offset
    points = []
    for a, b in zip(A, B):
        axis = (b - a) / np.linalg.norm(b - a)
        u = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
        u /= np.linalg.norm(u)
        v = np.cross(axis, u)
        n = int(np.linalg.norm(b - a) / spacing) + 2
        for phi in np.linspace(0.0, 2 * np.pi, 24, endpoint=False):
            around = np.cos(phi) * u + np.sin(phi) * v
            points += [a + t * (b - a) + r * around for t in np.linspace(0.0, 1.0, n)]
            points += [end + rho * around for end in (a, b) for rho in np.linspace(0, r, 4)]
    P = np.array(points)
    on_surface = np.abs(signed_distance(P, A, B, np.full(len(A), r))) < 1e-6
    P = P[on_surface & (P[:, 2] > Z_MIN_G)]
    return P + rng.normal(0.0, noise, P.shape)


def true_frames(generated, across, along):
    offset = np.array([across, 0.0, along])
    return {n: np.array(X.translation) + offset for n, X in generated.tool.frames().items()}


# One family in the default suite; the others (~4 s each) with the slow tests CI runs.
@pytest.mark.parametrize(
    "family, seed",
    [
        ("hook", 2),
        pytest.param("rake", 5, marks=pytest.mark.slow),
        pytest.param("two_bend", 1, marks=pytest.mark.slow),
    ],
)
def test_a_tool_is_named_and_its_frames_found_within_a_millimetre(family, seed):
    generated = generate_tool(family, seed)
    across, along = 0.004, -0.012
    P = surface_cloud(generated, across, along, seed)
    shape = measure_shape_from_points(P)
    assert shape.family == family, shape.as_dict()
    fitted = shape.best.frames_G()
    for name, p in true_frames(generated, across, along).items():
        if name != "grasp":  # the grasp along a handle that enters the hand is not seen
            assert np.linalg.norm(fitted[name] - p) < 1e-3, name
    assert shape.best.rms < 1e-3
    # Each family's cost is reported with the cloud it was fitted to: those refined on the
    # whole cloud (the named one among them), the others on the thinned one.
    costs = shape.as_dict()
    assert family in costs["cost"] and len(costs["cost"]) == len(shape.refined)
    assert set(costs["cost"]) | set(costs["cost_thinned_cloud"]) == set(shape.fits)
    if family == "rake":  # a discrete parameter is fitted too
        assert shape.best.params["tines"] == generated.params["tines"]


def test_the_fit_starts_nowhere_near_and_still_finds_the_tool():
    """From the ranges' middle only the family's own fit is near zero cost: another family
    leaves points far from its surface."""
    generated = generate_tool("t_head", 7)
    P = surface_cloud(generated, 0.0, 0.0)
    own = fit_family("t_head", P)
    other = fit_family("straight", P)
    assert own.rms < 1e-3 < 5 * 1e-3 < other.rms


@pytest.mark.slow  # ~1.2-2.4 s: with the slow tests CI runs
def test_a_cloud_of_no_family_is_other():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(600, 3))
    ball = 0.04 * d / np.linalg.norm(d, axis=1, keepdims=True) + [0.0, 0.0, 0.12]
    shape = measure_shape_from_points(ball)
    assert shape.family == OTHER and shape.best.rms > 0.003


def test_too_small_a_cloud_is_refused():
    with pytest.raises(ValueError, match="the views hold 5 points of the tool; at least 30"):
        measure_shape_from_points(np.zeros((5, 3)) + [0.0, 0.0, 0.1])


def test_signed_distance_is_negative_inside_and_the_gap_outside():
    A, B, r = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 0.1]]), np.array([0.01])
    P = np.array([[0.0, 0.0, 0.05], [0.03, 0.0, 0.05], [0.0, 0.0, 0.13], [0.03, 0.0, 0.14]])
    np.testing.assert_allclose(
        signed_distance(P, A, B, r), [-0.01, 0.02, 0.03, np.hypot(0.02, 0.04)], atol=1e-12
    )


def test_a_rods_end_is_held_to_the_points_though_only_its_near_side_is_seen():
    """A camera sees one side of a thick rod and its end face. Started 11 mm too long (more
    than its 10 mm radius), the fit brings the end back: the points' distances alone cannot
    (each end-face point, inside the overlong rod, is then nearer its side than its cap, so its
    signed distance is to the side and the cap's place does not change it), nor the support
    term (the overlong end is within r + slack of the end face); the overhang term does."""
    generated = generate_tool("straight", 0)
    params = {"length": 0.30, "radius": 0.010}
    rod = type(generated)("straight", 0, params, FAMILIES["straight"].build(params))
    P = surface_cloud(rod, 0.0, 0.0)
    P = P[P[:, 0] < 0.004]  # the near side and the near part of the end face
    long = FamilyFit("straight", {**params, "length": 0.311}, 0.0, 0.0, 0.0, 0.0)
    fit = fit_family("straight", P, start=long)
    assert abs(fit.frames_G()["tool_tip"][2] - 0.30) < 1e-3, fit
