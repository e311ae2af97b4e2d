"""A held hook measured from one camera view: pure functions of images, no Drake.

The hook (`robot.tool.HookTool`) carries three orange bands: at the grip end of the handle, at
the handle's far end (the corner) and at the hook's end. The straight tool's pipeline
(`perception.markers`) finds them: orange mask → blobs → the three largest; each band's pixels
back-projected to 3-D with the depth image. Then, in the camera frame C:

- the bands' axis points: a band's visible pixels sample the half of its surface that faces
  the camera, so their mean lies πR/4 off the band's axis towards the camera (R: the band's
  radius, measured across it in the image); moved back by that, the three means lie on the
  handle's and the hook's axes (whatever the view's tilt);
- the handle axis u: from the grip band's axis point to the corner band's;
- the grasp point A and the corner K: the grip band's and the corner band's outer ends along u
  (the extreme 3-D point plus the sub-pixel distance to the band's edge, as the straight tool's
  ends), on the axis;
- the hook's direction d: from K to the tip band's axis point; the tip: the tip band's outer
  end along d.

Handle length |AK| along u, hook length (tip − K)·d, angle acos(−u·d) (90°: an L; less: bent
back towards the hand). Which blob is which: the grip band is the one at the grip (where the
robot put it, as for the straight tool); of the two others the corner band is the one nearer
the handle's commanded direction in the image (the tip band is off it by the hook's
h sin(angle) ≥ 26 mm). A view is dropped, with the reason, when a band is missing, cut by the
image border or has no depth.

Frames and units as `perception.markers`: C = the camera's optical frame, pixels (u, v), SI
units, angles in degrees.
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np

from drake_tooluse.perception.markers import (
    GRIP_TOLERANCE,
    MIN_BLOB_AREA_PX,
    CameraIntrinsics,
    ViewSpec,
    _end_correction,
    _marker_points,
    _touches_border,
    find_blobs,
    orange_mask,
)

BANDS = ("grip", "corner", "tip")
QUANTITIES = ("handle_length", "hook_length", "angle", "grasp_along")
# The corner band lies within this angle of the handle's commanded direction in the image,
# seen from the grip band (deg); the tip band lies off it by the hook.
MAX_AXIS_ANGLE_DEG = 12.0
# A band's pixels whose depth differs from its median by more than this are left out (m):
# tighter than the straight tool's MARKER_DEPTH_TOLERANCE, because one orange pixel on a
# band's silhouette with the depth of what lies behind it, back-projected, moved the grasp
# point 4 mm; a band is 14 mm across, its visible half at most ~10 mm deep even tilted.
BAND_DEPTH_TOLERANCE = 0.01
# The grip band is taken as partly hidden (by the fingers: the hand holds the hook deeper)
# when it is shorter along the handle than the shorter of the other two bands by more than
# this (m); unhidden, the bands' lengths agree within ~0.5 mm.
MAX_GRIP_BAND_SHORTFALL = 0.001


@dc.dataclass
class HookViewSpec(ViewSpec):
    """What the robot knows about one view of the hook: the grip's pixel and depth (as for the
    straight tool) and the image direction (u, v), a unit vector, in which the handle leaves
    the grip (the projection of the commanded tool axis)."""

    axis_image: tuple[float, float] = (1.0, 0.0)


@dc.dataclass
class HookViewMeasurement:
    """The hook as one view sees it. `accepted` False: the view is dropped, `reason` says why.
    Points in the camera frame C (m): `p_CA` the grasp point (the grip band's outer end),
    `p_CK` the corner, `p_CT` the tip, all on the tool's axes; lengths in m, angle in degrees."""

    view: str
    accepted: bool
    reason: str = ""
    handle_length: float = math.nan
    hook_length: float = math.nan
    angle: float = math.nan
    band_radius: float = math.nan  # m, measured across the bands in the image
    p_CA: list = dc.field(default_factory=list)
    p_CK: list = dc.field(default_factory=list)
    p_CT: list = dc.field(default_factory=list)
    centroids_px: list = dc.field(default_factory=list)  # (u, v) per band: grip, corner, tip
    blob_count: int = 0

    def as_dict(self) -> dict:
        def f(x):
            return None if not math.isfinite(x) else float(x)

        return {
            "view": self.view,
            "accepted": self.accepted,
            "reason": self.reason,
            "handle_length_m": f(self.handle_length),
            "hook_length_m": f(self.hook_length),
            "angle_deg": f(self.angle),
            "band_radius_m": f(self.band_radius),
            "p_CA_m": [float(a) for a in self.p_CA],
            "p_CK_m": [float(a) for a in self.p_CK],
            "p_CT_m": [float(a) for a in self.p_CT],
            "centroids_px": [[float(a) for a in c] for c in self.centroids_px],
            "blob_count": int(self.blob_count),
        }


@dc.dataclass
class HookMeasurement:
    """All views of the hook measured so far (the estimator's state)."""

    views: list = dc.field(default_factory=list)  # HookViewMeasurement per view, in order

    @property
    def accepted(self) -> list:
        return [v for v in self.views if v.accepted]

    def values(self, quantity: str) -> np.ndarray:
        """`handle_length`, `hook_length` or `angle` of each accepted view."""
        return np.array([getattr(v, quantity) for v in self.accepted])

    def mean(self, quantity: str) -> float:
        values = self.values(quantity)
        return float(np.mean(values)) if values.size else math.nan

    def spread(self, quantity: str) -> float:
        """Largest minus smallest accepted view; NaN when none is accepted."""
        values = self.values(quantity)
        return float(np.ptp(values)) if values.size else math.nan


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x)


def _toward_camera(p_C: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """The unit vector from a point on a cylinder's axis towards the camera, square to the
    axis: the direction of the visible half's offset."""
    w = -p_C / np.linalg.norm(p_C)
    return _unit(w - w.dot(axis) * axis)


def _band_radius(points: np.ndarray, axis: np.ndarray, f: float) -> float:
    """A band's radius (m): its 3-D extent across `axis` in the image, plus half a pixel at
    each side (pixel centres lie inside the band's silhouette), halved."""
    c = points.mean(axis=0)
    across = _unit(np.cross(axis, -c))
    extent = np.ptp(points @ across)
    return 0.5 * (extent + c[2] / f)


def _band_points(blob, depth: np.ndarray, info: CameraIntrinsics):
    """A band's back-projected pixels p_CP (N, 3) and those pixels (u, v) (N, 2), as
    `markers._marker_points`, without those off the band's median depth by more than
    BAND_DEPTH_TOLERANCE."""
    points, pixels = _marker_points(blob, depth, info)
    if len(points) == 0:
        return points, pixels
    keep = np.abs(points[:, 2] - np.median(points[:, 2])) <= BAND_DEPTH_TOLERANCE
    return points[keep], pixels[keep]


def measure_hook_view(
    color_image: np.ndarray, depth_image: np.ndarray, info: CameraIntrinsics, view: HookViewSpec
) -> HookViewMeasurement:
    """Measures the hook in one view: handle length, hook length and angle, and the grasp,
    corner and tip points in C.

    color_image: (H, W, 3 or 4) uint8 RGB(A); depth_image: (H, W) or (H, W, 1) float32, m.
    A view is dropped (accepted=False, with the reason) when fewer than three bands are found,
    when no band lies at the grip, when neither other band lies along the handle, when a band
    touches the image border, or when a band has no valid depth."""
    depth = np.asarray(depth_image, np.float32).reshape(info.height(), info.width())
    if color_image.shape[:2] != (info.height(), info.width()):
        raise ValueError(
            f"color image is {color_image.shape[1]} x {color_image.shape[0]} px; "
            f"the camera gives {info.width()} x {info.height()} px"
        )
    mask = orange_mask(color_image)
    blobs = find_blobs(mask)
    out = HookViewMeasurement(view=view.name, accepted=False, blob_count=len(blobs))
    if len(blobs) < 3:
        out.reason = (
            f"{len(blobs)} orange bands found, 3 expected (grip, corner and tip): "
            "a band is hidden or out of frame"
        )
        return out
    f = info.focal_x()
    grip_px = np.asarray(view.grip_pixel, float)
    bands = blobs[:3]
    distances = [np.linalg.norm(b.centroid - grip_px) for b in bands]
    if min(distances) > GRIP_TOLERANCE * f / view.grip_depth:
        out.reason = (
            f"no band found within {GRIP_TOLERANCE * 100:.0f} cm of the grip at pixel "
            f"({grip_px[0]:.0f}, {grip_px[1]:.0f}): the grip band is missing (hidden or out "
            "of frame)"
        )
        return out
    grip = bands[int(np.argmin(distances))]
    others = [b for b in bands if b is not grip]
    axis_image = _unit(np.asarray(view.axis_image, float))
    angles = [
        math.degrees(math.acos(np.clip(_unit(b.centroid - grip.centroid) @ axis_image, -1, 1)))
        for b in others
    ]
    if min(angles) > MAX_AXIS_ANGLE_DEG:
        out.reason = (
            f"no band found along the handle (within {MAX_AXIS_ANGLE_DEG:g} deg of its "
            f"direction in the image; the nearest is {min(angles):.0f} deg off): the corner "
            "band is missing (hidden or out of frame)"
        )
        return out
    corner = others[int(np.argmin(angles))]
    tip = others[1 - int(np.argmin(angles))]
    out.centroids_px = [b.centroid.tolist() for b in (grip, corner, tip)]
    for name, blob in zip(BANDS, (grip, corner, tip)):
        side = _touches_border(blob, info.width(), info.height())
        if side:
            out.reason = (
                f"the {name} band touches the image's {side} border: it may be cut off "
                "(out of frame)"
            )
            return out
    clouds = [_band_points(b, depth, info) for b in (grip, corner, tip)]
    points = [c[0] for c in clouds]
    for name, pts in zip(BANDS, points):
        if len(pts) < MIN_BLOB_AREA_PX:
            out.reason = f"the {name} band has no valid depth ({len(pts)} pixels inside the range)"
            return out
    means = [p.mean(axis=0) for p in points]
    # The handle: axis points of the grip and corner bands, then their outer ends along it.
    u = _unit(means[1] - means[0])
    radius = _band_radius(points[0], u, f)
    offset = math.pi * radius / 4  # the visible half's mean, off the axis
    a_A = means[0] - offset * _toward_camera(means[0], u)
    a_K = means[1] - offset * _toward_camera(means[1], u)
    # The hook hides the corner band's edge on its side: across the handle (in the image),
    # the corner band's axis lies half the grip band's width inside its other edge.
    across = _unit(np.cross(u, -a_K))
    if across @ (means[2] - means[1]) < 0:
        across = -across
    grip_across = points[0] @ across
    target = np.min(points[1] @ across) + 0.5 * np.ptp(grip_across)
    a_K = a_K + (target - a_K @ across) * across
    a_A = a_A + (0.5 * (grip_across.min() + grip_across.max()) - a_A @ across) * across
    u = _unit(a_K - a_A)
    grip_along, corner_along = points[0] @ u, points[1] @ u
    i, j = int(np.argmin(grip_along)), int(np.argmax(corner_along))
    s_A = grip_along[i] - _end_correction(mask, clouds[0][1][i], points[0][i], u, -1.0, f)
    s_K = corner_along[j] + _end_correction(mask, clouds[1][1][j], points[1][j], u, +1.0, f)
    grip_extent = float(np.ptp(grip_along))
    p_CA = a_A + (s_A - a_A @ u) * u
    p_CK = a_K + (s_K - a_K @ u) * u
    # The hook: from the corner to the tip band's axis point, then its outer end along that.
    d = _unit(means[2] - p_CK)
    for _ in range(2):  # the offset's direction depends on d; d barely moves
        a_T = means[2] - offset * _toward_camera(means[2], d)
        d = _unit(a_T - p_CK)
    tip_along = points[2] @ d
    k = int(np.argmax(tip_along))
    s_T = tip_along[k] + _end_correction(mask, clouds[2][1][k], points[2][k], d, +1.0, f)
    p_CT = p_CK + (s_T - p_CK @ d) * d
    others_extent = min(float(np.ptp(corner_along)), float(np.ptp(tip_along)))
    if grip_extent < others_extent - MAX_GRIP_BAND_SHORTFALL:
        out.reason = (
            f"the grip band looks partly hidden (by the fingers?): it is "
            f"{grip_extent * 1000:.1f} mm long along the handle, the other bands at least "
            f"{others_extent * 1000:.1f} mm"
        )
        return out
    out.handle_length = float(s_K - s_A)
    out.hook_length = float(s_T - p_CK @ d)
    out.angle = math.degrees(math.acos(float(np.clip(-u @ d, -1.0, 1.0))))
    out.band_radius = float(radius)
    out.p_CA, out.p_CK, out.p_CT = p_CA.tolist(), p_CK.tolist(), p_CT.tolist()
    out.accepted = True
    return out
