"""A held tool's points from the head camera's depth views, fused in the gripper frame G: what
the shape measurement fits the tool families to (`robot.tool_fit`). No Drake here.

Each view's depth image gives the points within DEPTH_WINDOW of the camera (the held tool;
the sky and the room lie beyond it), cleaned of specks with OpenCV's connected components
(`view_points`). With the camera's pose in the gripper frame at the capture (X_GC), every
view's points go into G and are fused; what lies behind Z_MIN_G (the hand and the fingers) is
dropped, and the cloud thinned to one point per VOXEL cube (`fuse`).
"""

from __future__ import annotations

import cv2
import numpy as np

DEPTH_WINDOW = (0.45, 0.85)  # m from the camera: the held tool in every measurement view
MIN_BLOB_PIXELS = 20  # a depth blob smaller than this is a speck, not the tool
Z_MIN_G = 0.012  # m: the fingertips end here along G's z; the tool beyond
VOXEL = 0.003  # m
MAGENTA_BGR = (255, 0, 255)  # the tool's pixels in an annotated view
# What an annotated view's colours mean (BGR, words), as `perception.markers.ANNOTATION_COLORS`.
ANNOTATION_COLORS = {
    "points": (MAGENTA_BGR, "magenta: the points in the depth window (the tool, the hand)")
}


def view_points(depth: np.ndarray, intrinsics, depth_window=DEPTH_WINDOW) -> np.ndarray:
    """The points (n, 3) in the camera frame C (x right, y down, z ahead; m) of a depth image
    (h, w) within `depth_window`, specks of fewer than MIN_BLOB_PIXELS dropped.
    `intrinsics`: (focal_x, focal_y, center_x, center_y) px."""
    z = np.asarray(depth, np.float32).reshape(depth.shape[0], depth.shape[1])
    mask = np.isfinite(z) & (z > depth_window[0]) & (z < depth_window[1])
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), 8)
    big = np.zeros(count, bool)
    big[1:] = stats[1:, cv2.CC_STAT_AREA] >= MIN_BLOB_PIXELS
    v, u = np.nonzero(big[labels])
    d = z[v, u].astype(float)
    fx, fy, cx, cy = intrinsics
    return np.stack([(u - cx) * d / fx, (v - cy) * d / fy, d], axis=1)


def fuse(points_C: list, X_GC: list, voxel: float = VOXEL) -> np.ndarray:
    """The views' points (each (n, 3) in its camera frame) in G (each view's X_GC a 4×4
    matrix), beyond Z_MIN_G, one per `voxel` cube."""
    P = np.concatenate(
        [p @ np.asarray(X)[:3, :3].T + np.asarray(X)[:3, 3] for p, X in zip(points_C, X_GC)]
        or [np.zeros((0, 3))]
    )
    P = P[P[:, 2] > Z_MIN_G]
    if len(P) == 0:
        return P
    return thin(P, voxel)


def thin(P: np.ndarray, voxel: float) -> np.ndarray:
    """One point of P per `voxel` cube (the first, in P's order)."""
    if len(P) == 0:
        return P
    _, first = np.unique(np.floor(P / voxel).astype(np.int64), axis=0, return_index=True)
    return P[np.sort(first)]


def annotate_shape_view(color: np.ndarray, pixels: np.ndarray, name: str) -> np.ndarray:
    """A view as BGR with its points' pixels (n, 2: u, v: the tool and the hand, within the
    depth window) tinted magenta, the view's name and their count written on it."""
    bgr = cv2.cvtColor(np.ascontiguousarray(color[:, :, :3]), cv2.COLOR_RGB2BGR)
    if len(pixels):
        u = np.clip(np.rint(pixels[:, 0]).astype(int), 0, bgr.shape[1] - 1)
        v = np.clip(np.rint(pixels[:, 1]).astype(int), 0, bgr.shape[0] - 1)
        bgr[v, u] = (0.5 * bgr[v, u] + 0.5 * np.array(MAGENTA_BGR)).astype(np.uint8)
    text = f"{name}: {len(pixels)} points in the depth window (the hand's dropped in G)"
    cv2.putText(bgr, text, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (255, 255, 255), 1, cv2.LINE_AA)
    return bgr
