"""A held hook measured from camera views: pure functions of images, no Drake.

The hook (`robot.tool.HookTool`) carries three orange bands: at the grip end of the handle, at
the handle's far end (the corner) and at the hook's end. The straight tool's pipeline
(`perception.markers`) finds them: orange mask → blobs → the three largest; each band's pixels
back-projected to 3-D with the depth image. Two kinds of view:

`measure_hook_view`, a view square to the hook's plane, in the camera frame C:

- the bands' axis points: seen along its axis, a band's back-projected pixels lie on an arc
  of a circle of its radius; the circle's centre, fitted, is on the axis. Unlike the pixels'
  mean, it does not move when the hook hides part of the corner band or a side light leaves
  part of a band too dark to pass the orange mask (either moved the angle by ~2 deg);
- the handle axis u: from the grip band's axis point to the corner band's; when the near
  finger hides part or all of the grip band (the hand holds the hook deep; a grip band
  shorter than the corner band), the commanded tool axis (the tool runs along the gripper's z);
- the corner K: the corner band's outer end along u (the extreme 3-D point plus the sub-pixel
  distance to the band's edge, as the straight tool's ends), on the axis; the grasp point A:
  the grip band's outer end likewise, when the grip band is whole;
- the hook's direction d: from K to the tip band's axis point; the tip: the tip band's outer
  end along d. Hook length (tip − K)·d, angle acos(−u·d) (90°: an L; less: bent back towards
  the hand), handle length (K − A)·u when A is given.

`measure_grip_view`, a view with the fingers beside the grip band (the straight tool's views):
the grasp point A only, the grip band's outer end along the commanded tool axis. With the
fingers across the line of sight the band is seen between them even when held deep.

Which blob is which: the grip band is the one at the grip (where the robot put it, as for the
straight tool); of the two others the corner band is the one nearer the handle's commanded
direction in the image (the tip band is off it by the hook's h sin(angle) ≥ 26 mm). A view is
dropped, with the reason, when a band is missing, cut by the image border or has no depth.

Frames and units as `perception.markers`: C = the camera's optical frame, pixels (u, v), SI
units, angles in degrees.
"""

from __future__ import annotations

import dataclasses as dc
import math

import cv2
import numpy as np

from drake_tooluse.perception.markers import (
    GRIP_TOLERANCE,
    MIN_BLOB_AREA_PX,
    CameraIntrinsics,
    ViewSpec,
    draw_text_panel,
    edge_beyond_extreme_pixel,
    find_blobs,
    marker_points,
    orange_mask,
    touched_borders,
)
from drake_tooluse.validation import check_one_of

# The kinds of view: the hook's plane square to the camera, or the grip band between the
# fingers.
VIEW_KINDS = ("hook", "grip")
# The corner band lies within this angle of the handle's commanded direction in the image,
# seen from the grip band (deg); the tip band lies off it by the hook.
MAX_AXIS_ANGLE_DEG = 12.0
# A band's pixels whose depth differs from its median by more than this are left out (m):
# tighter than the straight tool's MARKER_DEPTH_TOLERANCE. An orange pixel on a band's
# silhouette can carry the depth of what lies behind it; back-projected, one 19 mm deep moved
# the grasp point 4 mm, one 9 mm deep a band's end 1.9 mm (the ray is inclined to the band).
# The visible half of a band square to the view lies within about -1.5..+3 mm of its median
# depth (R = 6.9 mm).
BAND_DEPTH_TOLERANCE = 0.005
# The grip band is taken as partly hidden (by the fingers: the hand holds the hook deeper)
# when it is shorter along the handle than the corner band by more than this (m); whole, the
# bands' lengths agree within ~0.5 mm.
MAX_GRIP_BAND_SHORTFALL = 0.001
# A band's surface point further than this from the circle first fitted across its axis is
# left out of the second fit (m).
MAX_ARC_RESIDUAL = 0.0005


@dc.dataclass
class HookViewSpec(ViewSpec):
    """What the robot knows about one view of the hook: the grip's pixel and depth (as for the
    straight tool), the commanded tool axis in C (a unit vector, `axis_C`) and its image
    direction at the grip (`axis_image`, unit (u, v)), and the kind of view (VIEW_KINDS)."""

    axis_C: tuple[float, float, float] = (0.0, 0.0, 1.0)
    axis_image: tuple[float, float] = (1.0, 0.0)
    kind: str = "hook"


@dc.dataclass
class HookViewMeasurement:
    """One view's result. `accepted` False: the view is dropped, `reason` says why. Points in
    the camera frame C (m), on the tool's axes: `p_CA` the grasp point (the grip band's outer
    end; empty when the band is partly hidden, `grip_reason` says so), `p_CK` the corner,
    `p_CT` the tip (empty in a grip view). Lengths in m, the angle in degrees; NaN where the
    view does not give them."""

    view: str
    kind: str
    accepted: bool
    reason: str = ""
    grip_reason: str = ""
    handle_length: float = math.nan  # image only: (K - A)·u, when A is given
    hook_length: float = math.nan
    angle: float = math.nan
    band_radius: float = math.nan  # m, measured across the grip band in the image
    p_CA: list = dc.field(default_factory=list)
    p_CK: list = dc.field(default_factory=list)
    p_CT: list = dc.field(default_factory=list)
    centroids_px: list = dc.field(default_factory=list)  # (u, v): corner, tip[, grip] / grip
    blob_count: int = 0

    def pixel_points(self) -> list:
        """(u, v) of what the view found of the hook: its markers' centroids."""
        return [tuple(c) for c in self.centroids_px]

    def as_dict(self) -> dict:
        def f(x):
            return None if not math.isfinite(x) else float(x)

        return {
            "view": self.view,
            "kind": self.kind,
            "accepted": self.accepted,
            "reason": self.reason,
            "grip_reason": self.grip_reason,
            "handle_length_image_m": f(self.handle_length),
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
    """All views measured so far (the estimator's state)."""

    views: list = dc.field(default_factory=list)  # HookViewMeasurement per view, in order

    @property
    def accepted(self) -> list:
        return [v for v in self.views if v.accepted]

    def values(self, quantity: str) -> np.ndarray:
        """`hook_length` or `angle` (or the image-only `handle_length`) of each accepted view
        that gives it."""
        values = np.array([getattr(v, quantity) for v in self.accepted], float)
        return values[np.isfinite(values)]

    def mean(self, quantity: str) -> float:
        values = self.values(quantity)
        return float(np.mean(values)) if values.size else math.nan

    def spread(self, quantity: str) -> float:
        """Largest minus smallest view; NaN when no view gives it."""
        values = self.values(quantity)
        return float(np.ptp(values)) if values.size else math.nan


def _unit(x: np.ndarray) -> np.ndarray:
    return x / np.linalg.norm(x)


def _axis_point(points: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, float]:
    """A point on a band's axis and the band's radius (m), from its surface points p_CP
    (N, 3) and its axis direction: the points, seen along the axis, lie on a circle (the arc
    the camera sees, whatever part of it the light or the hook leaves orange); its centre,
    fitted by least squares (Kåsa) and again without the points more than
    MAX_ARC_RESIDUAL off the first fit (a silhouette pixel can carry the depth behind it)."""
    c = points.mean(axis=0)
    e1 = _unit(np.cross(axis, -c))  # across the axis in the image
    e2 = np.cross(e1, axis)  # across the axis, along the line of sight
    x, y = (points - c) @ e1, (points - c) @ e2
    keep = np.ones(len(points), bool)
    for _ in range(2):
        A = np.column_stack([x[keep], y[keep], np.ones(keep.sum())])
        a, b, k = np.linalg.lstsq(A, -(x[keep] ** 2 + y[keep] ** 2), rcond=None)[0]
        cx, cy = -a / 2, -b / 2
        radius = math.sqrt(max(cx**2 + cy**2 - k, 0.0))
        keep = np.abs(np.hypot(x - cx, y - cy) - radius) <= MAX_ARC_RESIDUAL
    return c + cx * e1 + cy * e2, float(radius)


def _band_points(blob, depth: np.ndarray, info: CameraIntrinsics):
    """A band's back-projected pixels p_CP (N, 3) and those pixels (u, v) (N, 2), as
    `markers.marker_points`, without those off the band's median depth by more than
    BAND_DEPTH_TOLERANCE."""
    points, pixels = marker_points(blob, depth, info)
    if len(points) == 0:
        return points, pixels
    keep = np.abs(points[:, 2] - np.median(points[:, 2])) <= BAND_DEPTH_TOLERANCE
    return points[keep], pixels[keep]


def _check_image(color_image, depth_image, info: CameraIntrinsics) -> np.ndarray:
    if color_image.shape[:2] != (info.height(), info.width()):
        raise ValueError(
            f"color image is {color_image.shape[1]} x {color_image.shape[0]} px; "
            f"the camera gives {info.width()} x {info.height()} px"
        )
    return np.asarray(depth_image, np.float32).reshape(info.height(), info.width())


def _grip_band(blobs, view: HookViewSpec, f: float):
    """The blob nearest the grip pixel, or None if none lies within GRIP_TOLERANCE of it."""
    grip_px = np.asarray(view.grip_pixel, float)
    if not blobs:
        return None
    distances = [np.linalg.norm(b.centroid - grip_px) for b in blobs]
    k = int(np.argmin(distances))
    return blobs[k] if distances[k] <= GRIP_TOLERANCE * f / view.grip_depth else None


def _no_grip_reason(view: HookViewSpec) -> str:
    u, v = view.grip_pixel
    return (
        f"no band found within {GRIP_TOLERANCE * 100:.0f} cm of the grip at pixel "
        f"({u:.0f}, {v:.0f}): the grip band is missing (hidden or out of frame)"
    )


def _border_reason(name: str, blob, info: CameraIntrinsics) -> str:
    side = touched_borders(blob, info.width(), info.height())
    return f"the {name} band touches the image's {side} border: it may be cut off" if side else ""


def measure_grip_view(
    color_image: np.ndarray, depth_image: np.ndarray, info: CameraIntrinsics, view: HookViewSpec
) -> HookViewMeasurement:
    """The grasp point p_CA alone: the grip band's outer end along the commanded tool axis
    `view.axis_C` (its extreme 3-D point, plus the sub-pixel distance to its edge). Only its
    component along the tool counts (a point of the band's surface, off the axis across it).
    Dropped (with the reason) when no band lies at the grip, or it touches the image border or
    has no valid depth."""
    depth = _check_image(color_image, depth_image, info)
    mask = orange_mask(color_image)
    blobs = find_blobs(mask)
    out = HookViewMeasurement(view=view.name, kind="grip", accepted=False, blob_count=len(blobs))
    f = info.focal_x()
    grip = _grip_band(blobs, view, f)
    if grip is None:
        out.reason = _no_grip_reason(view)
        return out
    out.centroids_px = [grip.centroid.tolist()]
    out.reason = _border_reason("grip", grip, info)
    if out.reason:
        return out
    points, pixels = _band_points(grip, depth, info)
    if len(points) < MIN_BLOB_AREA_PX:
        out.reason = f"the grip band has no valid depth ({len(points)} pixels inside the range)"
        return out
    axis = _unit(np.asarray(view.axis_C, float))
    along = points @ axis
    i = int(np.argmin(along))
    p_CA = points[i] - edge_beyond_extreme_pixel(mask, pixels[i], points[i], axis, -1.0, f) * axis
    out.p_CA = p_CA.tolist()
    out.accepted = True
    return out


def measure_view_of_kind(color_image, depth_image, info: CameraIntrinsics, view: HookViewSpec):
    """`measure_hook_view` or `measure_grip_view`, by `view.kind` (one of VIEW_KINDS)."""
    if check_one_of(view.kind, VIEW_KINDS, "view kind") == "grip":
        return measure_grip_view(color_image, depth_image, info, view)
    return measure_hook_view(color_image, depth_image, info, view)


def measure_hook_view(
    color_image: np.ndarray, depth_image: np.ndarray, info: CameraIntrinsics, view: HookViewSpec
) -> HookViewMeasurement:
    """Measures the hook in a view square to its plane: hook length and angle, the corner and
    tip points in C, and the grasp point and the handle length when the grip band is whole.

    color_image: (H, W, 3 or 4) uint8 RGB(A); depth_image: (H, W) or (H, W, 1) float32, m.
    A view is dropped (accepted=False, with the reason) when the corner and the tip band are
    not both found, when neither lies along the handle, when a band touches the image border,
    or when a band has no valid depth. A grip band that is missing or partly hidden only
    leaves the grasp point out (`grip_reason` says why)."""
    depth = _check_image(color_image, depth_image, info)
    mask = orange_mask(color_image)
    blobs = find_blobs(mask)
    out = HookViewMeasurement(view=view.name, kind="hook", accepted=False, blob_count=len(blobs))
    f = info.focal_x()
    grip = _grip_band(blobs[:3], view, f)
    # Without the grip band (the near finger hides it when the hand holds the hook deep),
    # the corner and the tip band are the two largest blobs, told apart from the grip pixel.
    others = [b for b in blobs[:3] if b is not grip][:2]
    if len(others) < 2:
        out.reason = (
            f"{len(blobs)} orange bands found, at least the corner and the tip band expected: "
            "a band is hidden or out of frame"
        )
        return out
    origin = np.asarray(view.grip_pixel, float) if grip is None else grip.centroid
    axis_image = _unit(np.asarray(view.axis_image, float))
    angles = [
        math.degrees(math.acos(np.clip(_unit(b.centroid - origin) @ axis_image, -1, 1)))
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
    found = [("corner", corner), ("tip", tip)] + ([] if grip is None else [("grip", grip)])
    out.centroids_px = [b.centroid.tolist() for _, b in found]
    for name, blob in found:
        out.reason = _border_reason(name, blob, info)
        if out.reason:
            return out
    clouds = {name: _band_points(b, depth, info) for name, b in found}
    points = {name: c[0] for name, c in clouds.items()}
    for name, pts in points.items():
        if len(pts) < MIN_BLOB_AREA_PX:
            out.reason = f"the {name} band has no valid depth ({len(pts)} pixels inside the range)"
            return out
    means = {name: p.mean(axis=0) for name, p in points.items()}
    grip_whole = grip is not None
    if grip_whole:
        u = _unit(means["corner"] - means["grip"])
        grip_extent, corner_extent = (np.ptp(points[n] @ u) for n in ("grip", "corner"))
        if grip_extent < corner_extent - MAX_GRIP_BAND_SHORTFALL:
            out.grip_reason = (
                f"the grip band looks partly hidden (by the fingers): it is "
                f"{grip_extent * 1000:.1f} mm long along the handle, the corner band "
                f"{corner_extent * 1000:.1f} mm"
            )
            grip_whole = False
    else:
        out.grip_reason = "the grip band is hidden (by the fingers)"
    # The handle: with the whole grip band, through its axis point and the corner band's;
    # else along the commanded tool axis (the tool runs along the gripper's z).
    if grip_whole:
        u = _unit(means["corner"] - means["grip"])
        for _ in range(2):  # each fit is across the axis found before; it barely moves
            (a_A, r_A), (a_K, r_K) = (_axis_point(points[n], u) for n in ("grip", "corner"))
            u = _unit(a_K - a_A)
        radius = r_A
    else:
        u = _unit(np.array(view.axis_C))
        a_K, radius = _axis_point(points["corner"], u)
    corner_along = points["corner"] @ u
    j = int(np.argmax(corner_along))
    pixel, point = clouds["corner"][1][j], points["corner"][j]
    s_K = corner_along[j] + edge_beyond_extreme_pixel(mask, pixel, point, u, +1.0, f)
    p_CK = a_K + (s_K - a_K @ u) * u
    # The hook: from the corner to the tip band's axis point, then its outer end along that.
    d = _unit(means["tip"] - p_CK)
    for _ in range(2):
        a_T, _ = _axis_point(points["tip"], d)
        d = _unit(a_T - p_CK)
    tip_along = points["tip"] @ d
    k = int(np.argmax(tip_along))
    pixel, point = clouds["tip"][1][k], points["tip"][k]
    s_T = tip_along[k] + edge_beyond_extreme_pixel(mask, pixel, point, d, +1.0, f)
    out.hook_length = float(s_T - p_CK @ d)
    out.angle = math.degrees(math.acos(float(np.clip(-u @ d, -1.0, 1.0))))
    out.band_radius = float(radius)
    out.p_CK = p_CK.tolist()
    out.p_CT = (p_CK + out.hook_length * d).tolist()
    out.accepted = True
    if grip_whole:  # the grasp point: the grip band's outer end along the handle
        grip_along = points["grip"] @ u
        i = int(np.argmin(grip_along))
        pixel, point = clouds["grip"][1][i], points["grip"][i]
        s_A = grip_along[i] - edge_beyond_extreme_pixel(mask, pixel, point, u, -1.0, f)
        out.p_CA = (a_A + (s_A - a_A @ u) * u).tolist()
        out.handle_length = float(s_K - s_A)
    return out


def hook_view_text(measurement: HookViewMeasurement) -> list[str]:
    """One view's result in words, or why it was dropped."""
    m = measurement
    if not m.accepted:
        return [f"{m.view}: dropped - {m.reason}"]
    if m.kind == "grip":
        return [f"{m.view}: the grip band's outer end (the grasp point)"]
    lines = [f"{m.view}: hook {m.hook_length * 1000:.1f} mm at {m.angle:.1f} deg"]
    if m.p_CA:
        lines.append(f"handle {m.handle_length * 1000:.1f} mm in this view")
    else:
        lines.append(f"no grasp point: {m.grip_reason}")
    return lines


def annotate_hook_view(
    color_image: np.ndarray, measurement: HookViewMeasurement, info: CameraIntrinsics
) -> np.ndarray:
    """A BGR image for cv2.imwrite: the orange mask's pixels painted green, the measured
    points projected back (red: the grasp point; yellow: the corner and the tip, joined along
    the handle and the hook) and the result in words (`hook_view_text`) in the top left."""
    bgr = cv2.cvtColor(np.ascontiguousarray(color_image[:, :, :3]), cv2.COLOR_RGB2BGR)
    s = max(bgr.shape[1], 1) / 1280  # the drawing's scale
    bgr[orange_mask(color_image) > 0] = (0, 255, 0)

    def pixel(p_C):
        x, y, z = p_C
        return (
            int(round(info.center_x() + info.focal_x() * x / z)),
            int(round(info.center_y() + info.focal_y() * y / z)),
        )

    m = measurement
    line, dot = max(1, round(2 * s)), max(2, round(4 * s))
    if m.p_CK and m.p_CT:
        cv2.line(bgr, pixel(m.p_CK), pixel(m.p_CT), (0, 220, 255), line)
    if m.p_CA and m.p_CK:
        cv2.line(bgr, pixel(m.p_CA), pixel(m.p_CK), (0, 220, 255), line)
    for p in (m.p_CK, m.p_CT):
        if p:
            cv2.circle(bgr, pixel(p), dot, (0, 220, 255), -1)
    if m.p_CA:
        cv2.circle(bgr, pixel(m.p_CA), dot, (0, 0, 255), -1)
    margin = round(10 * s)
    draw_text_panel(bgr, hook_view_text(m), (margin, margin), 0.7 * s, max(1, round(2 * s)))
    return bgr
