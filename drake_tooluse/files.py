"""Atomic file writes: a result is either whole on disk or not there at all.

Files (`atomic_write_*`: text, bytes, JSON, PNG images and matplotlib figures) are written to
a temporary sibling and renamed over the target; directories (`atomic_dir`) are written into
a temporary sibling directory that takes the target's place only when complete.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import shutil
import tempfile
from pathlib import Path

import cv2
import numpy as np


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600; give the usual file mode
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_json(path: str | Path, data) -> Path:
    return atomic_write_text(path, json.dumps(data, indent=2) + "\n")


def atomic_write_image(path: str | Path, image: np.ndarray, bgr: bool = False) -> Path:
    """Writes an (H, W, 3 or 4) uint8 image as a PNG: RGB(A) channels, or OpenCV's BGR order
    with `bgr`; an alpha channel is dropped."""
    pixels = np.ascontiguousarray(np.asarray(image)[:, :, :3])
    ok, png = cv2.imencode(".png", pixels if bgr else cv2.cvtColor(pixels, cv2.COLOR_RGB2BGR))
    if not ok:
        raise RuntimeError(f"could not encode the image for {str(path)!r} as PNG")
    return atomic_write_bytes(path, png.tobytes())


def atomic_write_figure(path: str | Path, figure, dpi: int = 120) -> Path:
    """Writes a matplotlib figure as a PNG."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    return atomic_write_bytes(path, buffer.getvalue())


@contextlib.contextmanager
def atomic_dir(target: str | Path, replace: bool = False):
    """Yields a temporary sibling directory to write a directory's files into; on success it
    takes the place of `target`, on an error it is removed: the directory is either complete
    or as it was. Without `replace`, `target` must not exist or be empty (a run directory is
    never overwritten); with it, a complete old `target` is replaced (a policy, a checkpoint)."""
    target = Path(target)
    if not replace and target.exists() and (not target.is_dir() or any(target.iterdir())):
        raise FileExistsError(f"{str(target)!r} exists and is not empty; give a new directory")
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=target.parent, prefix=f".{target.name}.", suffix=".tmp"))
    try:
        yield tmp
        tmp.chmod(0o777 & ~_umask())  # mkdtemp makes 0700; give the usual directory mode
        old = target.with_name(f".{target.name}.old")
        if old.exists():
            shutil.rmtree(old)
        if target.exists():
            target.rename(old)
        tmp.rename(target)
        if old.exists():
            shutil.rmtree(old)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
