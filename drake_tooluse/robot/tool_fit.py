"""Fitting the tool families of `robot.tool_generator` to a held tool's points in the
gripper frame G (`perception.tool_shape` makes them from the camera's views): which family it
is, its parameters, the grasp, and so its working frames. No Drake here.

1. **Fit.** Every family is fitted to the cloud (`fit_family`): its continuous parameters and
   the grasp offsets (across: G's x; along: G's z) minimize, by `scipy.optimize.least_squares`
   within the family's ranges, each point's signed distance to the tool's solid (its
   skeleton's segments as flat-capped cylinders), plus a term for model parts that no point
   supports (a tool longer than the one seen) and one for a free end reaching past the points
   along its axis (an end the other two leave loose by up to its radius). A discrete parameter
   (a rake's tines) is fitted at each of its values. Each fit starts from the middle of the
   ranges and from a few seeded draws in them.
2. **Coarse to fine.** Every family is fitted to the cloud thinned to COARSE_VOXEL cubes; the
   REFINED best (by cost) again to the whole cloud, from there.
3. **Family.** The family of the lowest cost is named (`measure_shape_from_points`); where its
   RMS distance exceeds OTHER_RMS, or the fitted tool breaks a fabrication bound, the tool is
   "other". Its working frames are the fitted skeleton's, moved by the fitted grasp: frames
   in G.

The handle enters the hand, so the cloud cannot tell a longer handle held deeper from a
shorter one held less deep: the fit reports the handle as the visible tool makes it, and the
grasp along the handle as what is left; the frames in G, which the robot acts on, are the
same either way (they are what the accuracy is judged on).
"""

from __future__ import annotations

import dataclasses as dc
import itertools
import math

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial import cKDTree

from drake_tooluse.perception.tool_shape import Z_MIN_G, thin
from drake_tooluse.robot.tool import CompositeTool
from drake_tooluse.robot.tool_generator import FAMILIES, check_fabrication

# m, G's x and z of the grasp: the ranges of a scenario's and a belief's grasp offsets
GRASP_ACROSS_RANGE = (-0.01, 0.01)
GRASP_ALONG_RANGE = (-0.03, 0.03)
# Above this RMS distance of the cloud from the best family's fit, the tool is of no family
# (measured: a family's own tools fit within ~1.5 mm, another family's tens of mm).
OTHER_RMS = 0.003  # m
FIT_STARTS = 3  # the ranges' middle and two seeded draws
MAX_EVALUATIONS = 150  # per start
MODEL_SAMPLES = 16  # points along each model piece for the unsupported-part term
SUPPORT_SLACK = 0.002  # m: a model part this near the cloud (past its radius) is supported
# m: a free end this far past its nearest point along its axis is still held to the cloud
# (the points lie about a millimetre apart; a larger slack is a free overhang: it measured a
# 2 mm longer tip where 0.7 mm was measured without the term).
OVERHANG_SLACK = 0.0005
MAX_PIECES = 24  # the most pieces of any family's tool (an arc's segments and its handle)
MIN_POINTS = 30
COARSE_VOXEL = 0.008  # m: every family is first fitted to the cloud thinned this far
REFINED = 2  # the best families of the coarse fit, fitted again to the whole cloud
OTHER = "other"


def signed_distance(P: np.ndarray, A: np.ndarray, B: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Each point's signed distance (m; negative inside) to the union of the flat-capped
    cylinders from A[i] to B[i] of radius r[i]."""
    axis = B - A
    length = np.linalg.norm(axis, axis=1)
    u = axis / length[:, None]
    AP = P[:, None, :] - A[None]
    t = np.einsum("nkd,kd->nk", AP, u)  # along each axis
    radial = np.linalg.norm(AP - t[..., None] * u[None], axis=2)
    out_r = radial - r[None]  # > 0 outside the side
    out_t = np.maximum(-t, t - length[None])  # > 0 beyond a cap
    outside = np.hypot(np.maximum(out_r, 0), np.maximum(out_t, 0))
    inside = np.minimum(np.maximum(out_r, out_t), 0)
    return (outside + inside).min(axis=1)


@dc.dataclass
class FamilyFit:
    """One family fitted to a cloud: its parameters, the grasp (m: G's x and z of H's origin),
    the RMS signed distance of the cloud from the fitted tool (m) and the fit's cost (that
    distance and the unsupported-part term: what families are ranked by)."""

    family: str
    params: dict
    grasp_across: float
    grasp_along: float
    rms: float
    cost: float

    @property
    def tool(self) -> CompositeTool:
        """The fitted tool, in H."""
        return FAMILIES[self.family].build(self.params)

    def frames_G(self) -> dict:
        """The fitted tool's named frames' origins in G (m): H's, moved by the grasp."""
        offset = np.array([self.grasp_across, 0.0, self.grasp_along])
        skeleton = FAMILIES[self.family].skeleton(self.params)
        return {n: np.asarray(p, float) + offset for n, p in skeleton.working_frames().items()}


def _continuous(family) -> list[str]:
    return [n for n, spec in family.ranges.items() if not all(isinstance(v, int) for v in spec)]


def _discrete_choices(family) -> list[dict]:
    discrete = {
        n: range(spec[0], spec[1] + 1)
        for n, spec in family.ranges.items()
        if all(isinstance(v, int) for v in spec)
    }
    return [dict(zip(discrete, values)) for values in itertools.product(*discrete.values())]


class _Problem:
    """A family's fit to a cloud as least squares over x = (its continuous parameters, grasp
    across, grasp along), a discrete choice held fixed."""

    def __init__(self, family, P: np.ndarray, tree, fixed: dict):
        self.family, self.P, self.tree, self.fixed = family, P, tree, fixed
        self.names = _continuous(family)
        ranges = [family.ranges[n] for n in self.names] + [GRASP_ACROSS_RANGE, GRASP_ALONG_RANGE]
        self.lo, self.hi = np.array(ranges, float).T
        # The unsupported and overhang terms weigh as much as the cloud, whatever its size.
        self.weight = math.sqrt(len(P) / (MAX_PIECES * MODEL_SAMPLES))
        self.t = np.linspace(0.0, 1.0, MODEL_SAMPLES)
        self._shared = {}  # pieces -> per end, whether another piece starts or ends there

    def params(self, x) -> dict:
        return {**dict(zip(self.names, (float(v) for v in x[:-2]))), **self.fixed}

    def residuals(self, x) -> np.ndarray:
        params = self.params(x)
        A, B = self.family.skeleton(params).end_points()
        offset = np.array([x[-2], 0.0, x[-1]])
        A, B = A + offset, B + offset
        r = params["radius"]
        fit = signed_distance(self.P, A, B, np.full(len(A), r))
        S = (A[:, None, :] + self.t[None, :, None] * (B - A)[:, None, :]).reshape(-1, 3)
        gap, _ = self.tree.query(S)
        # Only what lies beyond the fingertips can be seen.
        unsupported = np.where(S[:, 2] > Z_MIN_G + 0.01, gap - r - SUPPORT_SLACK, 0.0)
        pad = np.zeros(MAX_PIECES * (MODEL_SAMPLES + 2) - len(S) - 2 * len(A))
        return np.concatenate(
            [
                fit,
                self.weight * np.maximum(unsupported, 0.0),
                self.weight * self._overhang(A, B),
                pad,
            ]
        )

    def _overhang(self, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Per piece end, how far a free end (one no other piece starts or ends at) reaches
        past the cloud along its piece's axis, beyond OVERHANG_SLACK (m): the axial distance
        from the end's centre back to its nearest point. Neither the points' distances hold an
        end to the tool's (a point on the true end face, inside an overlong piece, is nearer
        its side than its cap, so its signed distance does not change with the cap's place)
        nor the support term (an overlong end is still within r + slack of the true end)."""
        ends = np.concatenate([A, B])
        u = (B - A) / np.linalg.norm(B - A, axis=1, keepdims=True)
        outward = np.concatenate([-u, u])
        # Which ends meet another is the family's for a number of pieces (an arc's grows with
        # its sweep), whatever the parameters.
        shared = self._shared.get(len(A))
        if shared is None:
            shared = (np.linalg.norm(ends[:, None] - ends[None], axis=2) < 1e-9).sum(1) > 1
            self._shared[len(A)] = shared
        free = ~shared & (ends[:, 2] > Z_MIN_G + 0.01)
        out = np.zeros(len(ends))
        if free.any():
            _, nearest = self.tree.query(ends[free])
            axial = np.einsum("kd,kd->k", ends[free] - self.P[nearest], outward[free])
            out[free] = np.maximum(axial - OVERHANG_SLACK, 0.0)
        return out

    def solve(self, x0, max_evaluations: int):
        x0 = np.clip(x0, self.lo, self.hi)
        return least_squares(
            self.residuals,
            x0,
            bounds=(self.lo, self.hi),
            x_scale=(self.hi - self.lo) / 10,
            max_nfev=max_evaluations,
        )

    def fit(self, solution) -> FamilyFit:
        x = solution.x
        rms = float(np.sqrt(np.mean(solution.fun[: len(self.P)] ** 2)))
        return FamilyFit(
            self.family.name, self.params(x), float(x[-2]), float(x[-1]), rms, float(solution.cost)
        )


def fit_family(
    name: str, P: np.ndarray, tree=None, seed: int = 0, start: FamilyFit | None = None
) -> FamilyFit:
    """`name`'s tool fitted to the cloud P (n, 3) in G (module docstring, step 2): from the
    ranges' middle and FIT_STARTS - 1 seeded draws, at each discrete choice; or, given
    `start` (a fit of the same family), from it alone."""
    family = FAMILIES[name]
    tree = cKDTree(P) if tree is None else tree
    best = None
    choices = (
        _discrete_choices(family)
        if start is None
        else [{n: start.params[n] for n in _discrete_choices(family)[0]}]
    )
    rng = np.random.default_rng(seed)
    for fixed in choices:
        problem = _Problem(family, P, tree, fixed)
        if start is not None:
            x0s = [
                [start.params[n] for n in problem.names] + [start.grasp_across, start.grasp_along]
            ]
        else:
            middle = (problem.lo + problem.hi) / 2
            x0s = [middle] + [rng.uniform(problem.lo, problem.hi) for _ in range(FIT_STARTS - 1)]
        for x0 in x0s:
            x0 = np.array(x0, float)
            if start is None:
                x0[-2:] = 0.0  # the nominal grasp
            solution = problem.solve(x0, MAX_EVALUATIONS)
            if best is None or solution.cost < best[0].cost:
                best = (solution, problem)
    return best[1].fit(best[0])


@dc.dataclass
class ShapeFit:
    """A cloud's measurement: the family named (or OTHER), the best fit and every family's
    (coarse, on the thinned cloud, but for those refined on the whole cloud)."""

    family: str
    best: FamilyFit
    fits: dict  # family -> FamilyFit
    points: int
    refined: tuple  # the families fitted again on the whole cloud

    def as_dict(self) -> dict:
        """The measurement as JSON: each family's cost apart by the cloud it was fitted to
        (the two clouds' costs do not compare)."""
        return {
            "family": self.family,
            "fitted_family": self.best.family,
            "params": self.best.params,
            "grasp_across_m": self.best.grasp_across,
            "grasp_along_m": self.best.grasp_along,
            "rms_m": self.best.rms,
            "cost": {name: self.fits[name].cost for name in self.refined},
            "cost_thinned_cloud": {
                name: fit.cost for name, fit in self.fits.items() if name not in self.refined
            },
            "frames_G_m": {n: p.tolist() for n, p in self.best.frames_G().items()},
            "points": self.points,
        }


def measure_shape_from_points(P: np.ndarray, families=None, seed: int = 0) -> ShapeFit:
    """Every family (default all of FAMILIES) fitted to the cloud P (n, 3) in G, coarse to
    fine: each on the cloud thinned to COARSE_VOXEL cubes, the REFINED best of those (by
    cost) again on the whole cloud from there. The family of the lowest cost is named, or
    OTHER where its RMS distance exceeds OTHER_RMS or the fitted tool breaks a fabrication
    bound. Raises ValueError if the cloud is too small to fit (fewer than MIN_POINTS)."""
    if len(P) < MIN_POINTS:
        raise ValueError(
            f"the views hold {len(P)} points of the tool; at least {MIN_POINTS} are needed"
        )
    coarse = thin(P, COARSE_VOXEL)
    coarse_tree = cKDTree(coarse)
    fits = {name: fit_family(name, coarse, coarse_tree, seed) for name in (families or FAMILIES)}
    tree = cKDTree(P)
    refined = sorted(fits, key=lambda n: fits[n].cost)[:REFINED]
    for name in refined:
        fits[name] = fit_family(name, P, tree, start=fits[name])
    best = min((fits[n] for n in refined), key=lambda f: f.cost)
    try:
        check_fabrication(best.tool)
        fabricable = True
    except ValueError:
        fabricable = False
    family = best.family if best.rms <= OTHER_RMS and fabricable else OTHER
    return ShapeFit(family, best, fits, len(P), tuple(refined))
