"""The paper's OpenCV marker pipeline on one camera view: pure functions of images, no Drake.

colour image → HSV → orange mask → contours → a bounding box per blob → the two largest blobs
are the marker bands at the grip end and at the tip → the distance between their OUTER ends.

- `method="pixel"` (the paper's): the boxes' outer ends in the image, their pixel distance
  times a fixed metres per pixel (set by the depth at which the robot holds the grip). Right
  only for a tool square to the optical axis at that depth.
- `method="depth"` (default): each marker's pixels are back-projected to 3-D with the depth
  image and the intrinsics, and its outer end is its extreme point along the tool's 3-D axis
  (plus the sub-pixel distance to the band's edge). One outer-end pixel at one robust depth
  per marker, as first planned, read 2 mm long in the view where the tool is tilted in depth
  (its grip end's face is then in view, off the depth of the band's front); the 3-D extreme
  does not mind the tilt.
- A view is dropped, with the reason, when a marker is missing, cut by the image border or
  partly hidden (see `measure_view`).

`info` arguments are a pinhole camera's intrinsics with Drake's `CameraInfo` interface
(`width()`, `height()`, `focal_x()`, `focal_y()`, `center_x()`, `center_y()`). Frames: C = the
camera's optical frame (+z out of the lens, +x right in the image, +y down). Pixel (u, v): u to
the right, v down, pixel centres at integer coordinates. SI units. The camera itself and the
estimator system are in `systems.camera`.
"""

from __future__ import annotations

import dataclasses as dc
import math
from typing import Protocol

import cv2
import numpy as np

from drake_tooluse.limits import MAX_NOISE_SIGMA
from drake_tooluse.validation import check_in_range

METHODS = ("depth", "pixel")
# Orange in OpenCV's HSV (H in [0, 180), S and V in [0, 255]). The bands are (1, 0.45, 0): hue
# 27 deg = 13.5; the table and the box are orange-brown too (hue 14-15) but dull (S < 140),
# the robot is red (hue 0). V only excludes near-black pixels, so dimmer light passes.
ORANGE_HSV_LOW = (6, 170, 40)
ORANGE_HSV_HIGH = (22, 255, 255)
# Blobs smaller than this are noise, not markers (pixels).
MIN_BLOB_AREA_PX = 12
# A marker blob whose area, scaled by depth squared to a physical area, is below this fraction
# of the other's is taken as partly hidden.
MIN_AREA_RATIO = 0.4
# Marker pixels whose depth differs from the marker's median by more than this are not on it
# (m): the bands are 14 mm across, a tilted band a few mm deeper at one end.
MARKER_DEPTH_TOLERANCE = 0.03
# A blob counts as the grip marker when it lies within this distance of where the robot put
# the grip (m, in the tool plane): tracking error plus the band's own length.
GRIP_TOLERANCE = 0.04
# The renderer lightings the pipeline is tested under (see systems.camera.lighting_params).
LIGHTINGS = ("default", "dim_side")


class CameraIntrinsics(Protocol):
    """A pinhole camera's intrinsics, as Drake's `CameraInfo` gives them (px)."""

    def width(self) -> int: ...
    def height(self) -> int: ...
    def focal_x(self) -> float: ...
    def focal_y(self) -> float: ...
    def center_x(self) -> float: ...
    def center_y(self) -> float: ...


def check_noise_sigma(sigma, name: str = "noise sigma") -> float:
    """The colour noise: a standard deviation in [0, 50] grey levels."""
    return check_in_range(sigma, 0.0, MAX_NOISE_SIGMA, name, unit="grey levels")


def add_color_noise(color_image: np.ndarray, sigma: float, seed: int = 0) -> np.ndarray:
    """The same noise model on an (H, W, 3 or 4) uint8 array (for tests and offline use)."""
    sigma = check_noise_sigma(sigma)
    out = np.array(color_image, copy=True)
    rng = np.random.default_rng(seed)
    rgb = out[:, :, :3].astype(np.float32) + rng.normal(0.0, sigma, out[:, :, :3].shape)
    out[:, :, :3] = np.clip(np.rint(rgb), 0, 255).astype(np.uint8)
    return out


@dc.dataclass
class ViewSpec:
    """What the robot knows about one measurement view: where it put the grip in the image
    (the projection of its commanded gripper position, px) and at what depth along the
    optical axis (m), which sets the pixel variant's fixed scale. It does not know the tool's
    length."""

    name: str
    grip_pixel: tuple[float, float]
    grip_depth: float


@dc.dataclass
class Blob:
    """One connected orange region: its contour and statistics (pixel coordinates)."""

    contour: np.ndarray  # (N, 2) int, OpenCV (u, v)
    area_px: int
    centroid: np.ndarray  # (u, v)
    bbox: tuple[int, int, int, int]  # upright box: u, v, width, height (px)
    pixels: np.ndarray  # (M, 2) int (v, u) of the blob's pixels


@dc.dataclass
class ViewMeasurement:
    """The estimate from one view. `accepted` False: the view is dropped, `reason` says why.
    Grip marker first: `ends_px` are the boxes' outer ends in the image (px, the pixel
    variant), `ends_C` the markers' outer ends in 3-D, p_CA and p_CB in the camera frame C
    (m, the depth variant)."""

    view: str
    accepted: bool
    reason: str = ""
    length_depth: float = math.nan  # m, outer end to outer end along the tool's 3-D axis
    length_pixel: float = math.nan  # m, pixel distance x the fixed metres per pixel
    ends_px: list = dc.field(default_factory=list)
    ends_C: list = dc.field(default_factory=list)
    marker_depths: list = dc.field(default_factory=list)  # m
    marker_areas_px: list = dc.field(default_factory=list)
    boxes: list = dc.field(default_factory=list)  # per marker: 4 corners (u, v) of its box
    blob_count: int = 0

    def length(self, method: str) -> float:
        return self.length_depth if method == "depth" else self.length_pixel

    def pixel_points(self) -> list:
        """(u, v) of what the view found of the tool: its markers' boxes and outer ends."""
        return [tuple(c) for box in self.boxes for c in box] + [tuple(e) for e in self.ends_px]

    def as_dict(self) -> dict:
        def f(x):
            return None if x is None or not math.isfinite(x) else float(x)

        return {
            "view": self.view,
            "accepted": self.accepted,
            "reason": self.reason,
            "length_depth_m": f(self.length_depth),
            "length_pixel_m": f(self.length_pixel),
            "ends_px": [[float(a) for a in e] for e in self.ends_px],
            "ends_C_m": [[float(a) for a in e] for e in self.ends_C],
            "marker_depths_m": [f(d) for d in self.marker_depths],
            "marker_areas_px": [int(a) for a in self.marker_areas_px],
            "blob_count": int(self.blob_count),
        }


@dc.dataclass
class ToolLengthMeasurement:
    """All views measured so far and their combination (the mean of the accepted views)."""

    method: str
    views: list = dc.field(default_factory=list)  # ViewMeasurement per view, in order

    @property
    def accepted(self) -> list:
        return [v for v in self.views if v.accepted]

    @property
    def dropped(self) -> list:
        return [v for v in self.views if not v.accepted]

    def lengths(self, method: str | None = None) -> np.ndarray:
        m = self.method if method is None else method
        return np.array([v.length(m) for v in self.accepted])

    def length(self, method: str | None = None) -> float:
        """Mean of the accepted views (m); NaN when none is accepted."""
        values = self.lengths(method)
        return float(np.mean(values)) if values.size else math.nan

    def spread(self, method: str | None = None) -> float:
        """Largest minus smallest accepted view (m); NaN when none is accepted."""
        values = self.lengths(method)
        return float(np.ptp(values)) if values.size else math.nan

    def length_or_raise(self) -> float:
        """The mean length; a ValueError naming each view and what it missed if no view gave
        one."""
        if not self.accepted:
            detail = "; ".join(f"view {v.view!r}: {v.reason}" for v in self.views)
            raise ValueError(
                f"the tool length could not be measured in any of the "
                f"{len(self.views)} views: {detail or 'no view was captured'}"
            )
        return self.length()


def orange_mask(color_image: np.ndarray) -> np.ndarray:
    """Binary mask (uint8, 0/255) of the orange pixels of an RGB(A) image. Not opened: that
    would cut the bands' thin dark edges (their ends); specks of noise are left to the blob
    size filter (MIN_BLOB_AREA_PX)."""
    rgb = np.ascontiguousarray(color_image[:, :, :3])
    hsv = cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)
    return cv2.inRange(hsv, np.array(ORANGE_HSV_LOW, np.uint8), np.array(ORANGE_HSV_HIGH, np.uint8))


def find_blobs(mask: np.ndarray, min_area_px: int = MIN_BLOB_AREA_PX) -> list[Blob]:
    """The mask's outer contours as blobs, largest first (area = pixels inside the contour)."""
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    blobs = []
    for contour in contours:
        u, v, w, h = cv2.boundingRect(contour)
        local = np.zeros((h, w), np.uint8)
        cv2.drawContours(local, [contour - [u, v]], -1, 255, thickness=cv2.FILLED)
        local &= mask[v : v + h, u : u + w]
        vv, uu = np.nonzero(local)
        if vv.size < min_area_px:
            continue
        pixels = np.column_stack([vv + v, uu + u])
        blobs.append(
            Blob(
                contour=contour.reshape(-1, 2),
                area_px=int(vv.size),
                centroid=np.array([uu.mean() + u, vv.mean() + v]),
                bbox=(u, v, w, h),
                pixels=pixels,
            )
        )
    blobs.sort(key=lambda b: b.area_px, reverse=True)
    return blobs


def _outer_end(blob: Blob, d: np.ndarray, sign: float):
    """The outer end (u, v) of a marker blob on the tool line of image direction `d`, and the
    corners of its bounding box aligned with `d`. `sign` -1: the end towards -d.

    Contour points are pixel centres; a pixel is orange when its centre is on the band, so the
    band's edge lies on average half a pixel beyond the last centre: the end is moved out by
    0.5 px. For a horizontal or vertical tool the box is the upright box of the paper."""
    n = np.array([-d[1], d[0]])
    pts = blob.contour.astype(float)
    along, across = pts @ d, pts @ n
    a_lo, a_hi = along.min() - 0.5, along.max() + 0.5
    c_lo, c_hi = across.min() - 0.5, across.max() + 0.5
    a_end = a_lo if sign < 0 else a_hi
    end = a_end * d + 0.5 * (c_lo + c_hi) * n
    corners = [a * d + c * n for a, c in ((a_lo, c_lo), (a_hi, c_lo), (a_hi, c_hi), (a_lo, c_hi))]
    return end, corners


def back_project_pixels(u, v, z, info: CameraIntrinsics) -> np.ndarray:
    """p_CP (N, 3) of pixels (u, v) at depths z (m), by the pinhole model of `info`."""
    return np.column_stack(
        [(u - info.center_x()) * z / info.focal_x(), (v - info.center_y()) * z / info.focal_y(), z]
    )


def marker_points(blob: Blob, depth: np.ndarray, info: CameraIntrinsics):
    """p_CP of each of the marker's pixels with a valid depth, back-projected (m), (N, 3), and
    those pixels (u, v), (N, 2).

    Pixels whose depth is more than MARKER_DEPTH_TOLERANCE from the marker's median depth are
    left out: on a real camera edge pixels mix the marker's depth with the background's."""
    z = depth[blob.pixels[:, 0], blob.pixels[:, 1]].astype(float)
    valid = np.isfinite(z) & (z > 0)
    if not np.any(valid):
        return np.zeros((0, 3)), np.zeros((0, 2), int)
    z_median = np.median(z[valid])
    keep = valid & (np.abs(z - z_median) <= MARKER_DEPTH_TOLERANCE)
    v, u, z = blob.pixels[keep, 0], blob.pixels[keep, 1], z[keep]
    return back_project_pixels(u, v, z, info), np.column_stack([u, v])


def edge_beyond_extreme_pixel(
    mask: np.ndarray, pixel, p_CE: np.ndarray, u_C: np.ndarray, sign: float, f: float
) -> float:
    """How far (m, along the tool axis) the band's edge lies beyond its extreme pixel centre.

    A pixel is orange when its centre is on the band, so the edge lies between the extreme
    orange pixel centre and the nearest non-orange pixel centre beyond it along the tool's
    image direction (within a pixel across): half that gap is the unbiased estimate. For a
    tool square to the pixel grid the gap is one pixel; tilted, the rows' phases differ and it
    is smaller. The gap in pixels becomes metres with the image's rate of motion along u_C at
    p_CE: `f |u_xy - u_z p_xy / z| / z` pixels per metre."""
    x, y, z = p_CE
    d = np.array([u_C[0] - u_C[2] * x / z, u_C[1] - u_C[2] * y / z]) * sign
    image_rate = f * np.linalg.norm(d) / z
    d /= np.linalg.norm(d)
    u, v = int(pixel[0]), int(pixel[1])
    gap = 1.0
    height, width = mask.shape
    for dv in range(-2, 3):
        for du in range(-2, 3):
            uu, vv = u + du, v + dv
            if not (0 <= uu < width and 0 <= vv < height) or mask[vv, uu]:
                continue
            along = du * d[0] + dv * d[1]
            if 1e-9 < along < gap and abs(-du * d[1] + dv * d[0]) <= 1.0:
                gap = along
    return 0.5 * gap / image_rate


def touched_borders(blob: Blob, width: int, height: int) -> str:
    """The image borders a blob's box touches in a `width` x `height` px image, in words
    ("left", "top and right", ...); "" when none (a blob on a border may be cut off)."""
    u, v, w, h = blob.bbox
    sides = [
        name
        for name, hit in (
            ("left", u <= 0),
            ("top", v <= 0),
            ("right", u + w >= width),
            ("bottom", v + h >= height),
        )
        if hit
    ]
    return " and ".join(sides)


def measure_view(
    color_image: np.ndarray, depth_image: np.ndarray, info: CameraIntrinsics, view: ViewSpec
) -> ViewMeasurement:
    """Measures the tool in one view (both the depth and the pixel variant).

    color_image: (H, W, 3 or 4) uint8 RGB(A); depth_image: (H, W) or (H, W, 1) float32, m.
    A view is dropped (accepted=False, with the reason) when fewer than two marker blobs are
    found, when no blob lies at the grip, when a marker touches the image border (it may be
    cut off), when one marker is much smaller than the other (partly hidden), or when a marker
    has no valid depth."""
    depth = np.asarray(depth_image, np.float32).reshape(info.height(), info.width())
    if color_image.shape[:2] != (info.height(), info.width()):
        raise ValueError(
            f"color image is {color_image.shape[1]} x {color_image.shape[0]} px; "
            f"the camera gives {info.width()} x {info.height()} px"
        )
    mask = orange_mask(color_image)
    blobs = find_blobs(mask)
    out = ViewMeasurement(view=view.name, accepted=False, blob_count=len(blobs))
    f = info.focal_x()
    grip_px = np.asarray(view.grip_pixel, float)
    tolerance_px = GRIP_TOLERANCE * f / view.grip_depth
    near_grip = [b for b in blobs[:2] if np.linalg.norm(b.centroid - grip_px) <= tolerance_px]
    if not blobs:
        out.reason = "no orange marker found: both the grip marker and the tip marker are missing"
        return out
    if len(blobs) == 1:
        missing = "tip marker" if near_grip else "grip marker"
        out.reason = (
            f"only one orange marker found: the {missing} is missing (hidden or out of frame)"
        )
        out.marker_areas_px = [blobs[0].area_px]
        return out
    if not near_grip:
        out.reason = (
            f"no marker found within {GRIP_TOLERANCE * 100:.0f} cm of the grip at "
            f"pixel ({grip_px[0]:.0f}, {grip_px[1]:.0f}): the grip marker is missing "
            "(hidden or out of frame)"
        )
        return out
    grip = near_grip[0]
    tip = blobs[1] if grip is blobs[0] else blobs[0]
    out.marker_areas_px = [grip.area_px, tip.area_px]
    for name, blob in (("grip marker", grip), ("tip marker", tip)):
        side = touched_borders(blob, info.width(), info.height())
        if side:
            out.reason = (
                f"the {name} touches the image's {side} border: it may be cut off (out of frame)"
            )
            return out
    # The paper's pixel variant: upright (tool-aligned) boxes, the outer ends in the image.
    d = tip.centroid - grip.centroid
    d /= np.linalg.norm(d)
    grip_end, grip_box = _outer_end(grip, d, -1.0)
    tip_end, tip_box = _outer_end(tip, d, +1.0)
    out.ends_px = [grip_end.tolist(), tip_end.tolist()]
    out.boxes = [np.array(grip_box).tolist(), np.array(tip_box).tolist()]
    out.length_pixel = float(np.linalg.norm(tip_end - grip_end) * view.grip_depth / f)
    # The depth variant: each marker's pixels back-projected to 3-D; the outer ends are the
    # markers' extreme points along the tool's 3-D axis. Unlike one outer-end pixel at one
    # depth, this holds when the tool is tilted in depth and the grip end's face is in view.
    clouds = [marker_points(b, depth, info) for b in (grip, tip)]
    points = [c[0] for c in clouds]
    for name, pts in zip(("grip marker", "tip marker"), points):
        if len(pts) < MIN_BLOB_AREA_PX:
            out.reason = f"the {name} has no valid depth ({len(pts)} pixels inside the depth range)"
            return out
    out.marker_depths = [float(np.median(p[:, 2])) for p in points]
    physical_area = [b.area_px * z * z for b, z in zip((grip, tip), out.marker_depths)]
    ratio = min(physical_area) / max(physical_area)
    if ratio < MIN_AREA_RATIO:
        small = "grip marker" if physical_area[0] < physical_area[1] else "tip marker"
        out.reason = (
            f"the {small} looks partly hidden: its area is {ratio * 100:.0f} % of the "
            f"other marker's (at least {MIN_AREA_RATIO * 100:.0f} % expected)"
        )
        return out
    u_C = points[1].mean(axis=0) - points[0].mean(axis=0)
    u_C /= np.linalg.norm(u_C)
    grip_along, tip_along = points[0] @ u_C, points[1] @ u_C
    i, j = np.argmin(grip_along), np.argmax(tip_along)
    p_CA, p_CB = points[0][i], points[1][j]
    grip_out = edge_beyond_extreme_pixel(mask, clouds[0][1][i], p_CA, u_C, -1.0, f)
    tip_out = edge_beyond_extreme_pixel(mask, clouds[1][1][j], p_CB, u_C, +1.0, f)
    p_CA, p_CB = p_CA - grip_out * u_C, p_CB + tip_out * u_C
    out.ends_C = [p_CA.tolist(), p_CB.tolist()]
    out.length_depth = float(tip_along[j] - grip_along[i] + grip_out + tip_out)
    out.accepted = True
    return out


# annotate_view's colours (BGR) and what each shows, for its legend and a figure's.
ANNOTATION_COLORS = {
    "mask": ((0, 255, 0), "green: the pixels the orange mask found (the marker bands)"),
    "box": ((255, 0, 0), "blue: each marker's bounding box"),
    "pixel": ((0, 0, 255), "red: the boxes' outer ends in the image (pixel variant)"),
    "depth": ((0, 220, 255), "yellow: the outer ends found in 3-D (depth variant)"),
}


def measurement_text(measurement: ViewMeasurement) -> list[str]:
    """The result of one view in words: the depth variant, which the robot uses, and the
    paper's pixel variant with why it differs; or why the view was dropped."""
    if not measurement.accepted:
        return [f"{measurement.view}: dropped - {measurement.reason}"]
    return [
        f"{measurement.view}: depth variant {measurement.length_depth * 1000:.1f} mm "
        "(what the robot uses)",
        f"pixel variant {measurement.length_pixel * 1000:.1f} mm (the paper's fixed m/px, exact",
        "  only square to the camera: a tool tilted in depth looks shorter)",
    ]


def draw_text_panel(bgr, lines, origin, scale, thickness, swatches=None) -> int:
    """`lines` of text on a whitened panel at `origin` (top left, px), each after a colour
    swatch when `swatches` gives one (BGR or None). Returns the panel's bottom row."""
    font = cv2.FONT_HERSHEY_SIMPLEX
    sizes = [cv2.getTextSize(line, font, scale, thickness)[0] for line in lines]
    step = int(max(h for _, h in sizes) * 1.8)
    pad = max(2, step // 4)
    indent = step if swatches else 0
    x0, y0 = origin
    width = max(w for w, _ in sizes) + indent + 2 * pad
    x1, y1 = min(x0 + width, bgr.shape[1] - 1), min(y0 + step * len(lines) + pad, bgr.shape[0] - 1)
    panel = bgr[y0:y1, x0:x1]
    panel[:] = (0.25 * panel + 0.75 * 255).astype(np.uint8)
    for i, line in enumerate(lines):
        base = y0 + pad + step * (i + 1) - step // 3
        if swatches and swatches[i] is not None:
            side = step // 2
            cv2.rectangle(bgr, (x0 + pad, base - side), (x0 + pad + side, base), swatches[i], -1)
        cv2.putText(
            bgr, line, (x0 + pad + indent, base), font, scale, (0, 0, 0), thickness, cv2.LINE_AA
        )
    return y1


def annotate_view(
    color_image: np.ndarray, measurement: ViewMeasurement, info: CameraIntrinsics | None = None
) -> np.ndarray:
    """A BGR image for cv2.imwrite: the orange mask's pixels painted green, each marker's box
    (blue), the segment between the boxes' outer ends (red: the pixel variant), the 3-D outer
    ends projected back (yellow dots: the depth variant; needs `info`), insets of the two
    markers in the top right corner, the result in words (`measurement_text`) and a legend of
    the colours (ANNOTATION_COLORS) in the top left. Every mark is drawn on the image itself,
    in its legend colour, so a crop to the tool keeps all that the legend lists; lines, text
    and insets scale with the image (as drawn at 1280 px wide)."""
    bgr = cv2.cvtColor(np.ascontiguousarray(color_image[:, :, :3]), cv2.COLOR_RGB2BGR)
    s = max(bgr.shape[1], 1) / 1280  # the drawing's scale
    line = max(1, round(2 * s))
    colors = {k: c for k, (c, _) in ANNOTATION_COLORS.items()}
    mask = orange_mask(color_image) > 0
    bgr[mask] = colors["mask"]  # the swatch's colour, not a blend with what is under it
    base = bgr.copy()
    for box in measurement.boxes:
        cv2.polylines(bgr, [np.rint(np.array(box)).astype(np.int32)], True, colors["box"], line)
    if len(measurement.ends_px) == 2:
        a, b = (tuple(int(round(x)) for x in e) for e in measurement.ends_px)
        cv2.line(bgr, a, b, colors["pixel"], line)
    ends_3d = []
    if info is not None:
        ends_3d = [
            (info.center_x() + info.focal_x() * x / d, info.center_y() + info.focal_y() * y / d)
            for x, y, d in measurement.ends_C
        ]
    dot = max(2, round(4 * s))
    for p in ends_3d:
        cv2.circle(bgr, (int(round(p[0])), int(round(p[1]))), dot, colors["depth"], -1)
    zoom, half = max(2, round(6 * s)), 16  # each inset: a 33 x 33 px window, magnified
    side = (2 * half + 1) * zoom
    top, gap = round(40 * s), round(10 * s)
    for i, end in enumerate(measurement.ends_px):
        u0 = min(max(int(round(end[0])), half), bgr.shape[1] - half - 1) - half
        v0 = min(max(int(round(end[1])), half), bgr.shape[0] - half - 1) - half
        inset = cv2.resize(
            base[v0 : v0 + side // zoom, u0 : u0 + side // zoom],
            (side, side),
            interpolation=cv2.INTER_NEAREST,
        )

        def z(p, u0=u0, v0=v0):  # image pixel -> inset pixel
            return (int(round((p[0] - u0 + 0.5) * zoom)), int(round((p[1] - v0 + 0.5) * zoom)))

        for box in measurement.boxes:
            cv2.polylines(inset, [np.array([z(c) for c in box], np.int32)], True, colors["box"], 2)
        cv2.line(inset, z(measurement.ends_px[0]), z(measurement.ends_px[1]), colors["pixel"], 2)
        for p in ends_3d:
            cv2.circle(inset, z(p), max(2, round(5 * s)), colors["depth"], -1)
        x0 = bgr.shape[1] - (len(measurement.ends_px) - i) * (side + gap)
        if x0 >= 0 and top + side <= bgr.shape[0]:
            bgr[top : top + side, x0 : x0 + side] = inset
            cv2.rectangle(bgr, (x0, top), (x0 + side - 1, top + side - 1), (0, 0, 0), 1)
            draw_text_panel(
                bgr,
                [("grip", "tip")[i] + f" marker x{zoom}"],
                (x0 + 1, top + side - round(24 * s)),
                0.45 * s,
                max(1, round(s)),
            )
    margin = round(10 * s)
    bottom = draw_text_panel(
        bgr, measurement_text(measurement), (margin, margin), 0.7 * s, max(1, round(2 * s))
    )
    draw_text_panel(
        bgr,
        [label for _, label in ANNOTATION_COLORS.values()],
        (margin, bottom + margin),
        0.5 * s,
        max(1, round(s)),
        [color for color, _ in ANNOTATION_COLORS.values()],
    )
    return bgr
