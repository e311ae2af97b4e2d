"""The docs' Meshcat screenshots, taken with headless Chromium from fresh recordings, and a
check that they are current that needs no browser.

Each screenshot in `SCREENSHOTS` is made from a recording built the way its command builds it
(`simulate_meshcat.png`: docs/guide/simulation.md's `drake-tooluse simulate ... --record`),
opened in headless Chromium at a fixed window size and photographed once the playback has
ended (Drake's animation holds its last frame). Beside each PNG, `<name>.json` records what the picture
shows: a digest of the recording's scene (`scene_digest`) and the camera and window.

A pixel comparison would not survive another machine's renderer, so `render_all(check=True)`
rebuilds the recording and compares that digest instead. The digest is taken over the Meshcat
commands the HTML carries (`scene_commands`: every object, transform and property of the scene
tree, the camera, and the playback reduced to its length and last frame), with three.js's
random uuids renumbered and every number rounded to 1e-4 (0.1 mm, 0.1 mrad), far below a pixel.
"""

from __future__ import annotations

import base64
import hashlib
import json
import math
import re
import shutil
import struct
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pydrake.math import RigidTransform, RollPitchYaw

from drake_tooluse.builders.trajectory_diagram import simulate_waypoints
from drake_tooluse.files import atomic_write_bytes, atomic_write_json
from drake_tooluse.paths import DEFAULT_SCENARIO
from drake_tooluse.robot.model import TOOL_DOWN_RPY
from drake_tooluse.validation import EnvironmentProblem
from drake_tooluse.world.scenario import load_scenario

CHROMIUM_NAMES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
DIGITS = 4  # numbers in the digest are rounded to this many decimals (m, rad)
# Chromium's virtual time runs past the end of the playback by this much before the picture.
SETTLE_MS = 4000
CHROMIUM_TIMEOUT_S = 300


@dataclass(frozen=True)
class Screenshot:
    """A docs screenshot: how its recording is made, the command a user types for it, and
    the browser window it is taken in (px)."""

    record: Callable[[Path], Path]
    command: str
    window: tuple[int, int] = (1280, 800)


# docs/guide/simulation.md's `simulate` example (its defaults: --move-time 1.0 --dwell 1.5,
# push.yaml).
SIMULATE_WAYPOINTS = ((0.66, -0.2, -0.12), (0.72, 0.0, -0.15), (0.58, -0.35, -0.1))


def _simulate_recording(path: Path) -> Path:
    waypoints = [RigidTransform(RollPitchYaw(*TOOL_DOWN_RPY), list(p)) for p in SIMULATE_WAYPOINTS]
    run = simulate_waypoints(
        load_scenario(DEFAULT_SCENARIO), waypoints, move_time=1.0, dwell=1.5, record=path
    )
    return run.recording


SCREENSHOTS = {
    "simulate_meshcat": Screenshot(
        _simulate_recording,
        "drake-tooluse simulate --tip-waypoints "
        + " ".join(",".join(str(v) for v in p) for p in SIMULATE_WAYPOINTS)
        + " --record HTML",
    ),
}


# -- Meshcat's commands in a saved recording -------------------------------------------------


class _Unpacker:
    """The msgpack subset Meshcat sends (maps, arrays, strings, numbers, bin and ext for typed
    arrays); bin and ext data come back as bytes, an ext as (type, bytes)."""

    def __init__(self, data: bytes):
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        if self.pos + n > len(self.data):
            raise ValueError("truncated msgpack data in the recording")
        out = self.data[self.pos : self.pos + n]
        self.pos += n
        return out

    def unpack(self, fmt: str):
        return struct.unpack(">" + fmt, self.take(struct.calcsize(">" + fmt)))[0]

    def value(self):
        b = self.take(1)[0]
        if b <= 0x7F:
            return b
        if b >= 0xE0:
            return b - 0x100
        if 0x80 <= b <= 0x8F:
            return self.map(b & 0x0F)
        if 0x90 <= b <= 0x9F:
            return [self.value() for _ in range(b & 0x0F)]
        if 0xA0 <= b <= 0xBF:
            return self.take(b & 0x1F).decode()
        fixed = {0xC0: None, 0xC2: False, 0xC3: True}
        if b in fixed:
            return fixed[b]
        numbers = {0xCA: "f", 0xCB: "d", 0xCC: "B", 0xCD: "H", 0xCE: "I", 0xCF: "Q"}
        numbers.update({0xD0: "b", 0xD1: "h", 0xD2: "i", 0xD3: "q"})
        if b in numbers:
            return self.unpack(numbers[b])
        lengths = {0: "B", 1: "H", 2: "I"}
        if 0xC4 <= b <= 0xC6:  # bin 8/16/32
            return bytes(self.take(self.unpack(lengths[b - 0xC4])))
        if 0xC7 <= b <= 0xC9:  # ext 8/16/32
            n = self.unpack(lengths[b - 0xC7])
            return (self.unpack("b"), bytes(self.take(n)))
        if 0xD4 <= b <= 0xD8:  # fixext 1/2/4/8/16
            kind = self.unpack("b")
            return (kind, bytes(self.take(1 << (b - 0xD4))))
        if 0xD9 <= b <= 0xDB:  # str 8/16/32
            return self.take(self.unpack(lengths[b - 0xD9])).decode()
        if b in (0xDC, 0xDD):
            return [self.value() for _ in range(self.unpack("H" if b == 0xDC else "I"))]
        if b in (0xDE, 0xDF):
            return self.map(self.unpack("H" if b == 0xDE else "I"))
        raise ValueError(f"unknown msgpack type byte 0x{b:02x} in the recording")

    def map(self, n: int) -> dict:
        out = {}
        for _ in range(n):
            key = self.value()
            out[key] = self.value()
        return out


_COMMAND = re.compile(r'fetch\("data:application/octet-binary;base64,([A-Za-z0-9+/=]+)"\)')


def scene_commands(html: str) -> list[dict]:
    """The Meshcat commands a recording saved by `Meshcat.StaticHtml` replays when it opens,
    decoded, in their order."""
    commands = []
    for blob in _COMMAND.findall(html):
        unpacker = _Unpacker(base64.b64decode(blob))
        commands.append(unpacker.value())
    if not commands:
        raise ValueError("the file holds no Meshcat scene (not a Meshcat.StaticHtml recording?)")
    return commands


_UUID = re.compile(r"^[0-9a-fA-F]{8}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{4}-[0-9a-fA-F]{12}$")


def _normalised(value, uuids: dict):
    """`value` with uuids renumbered in order of appearance, numbers rounded to DIGITS, bytes
    as their digest: what stays the same from run to run and machine to machine."""
    if isinstance(value, bool) or value is None:
        return value
    if isinstance(value, float):
        return round(value, DIGITS) + 0.0 if math.isfinite(value) else str(value)
    if isinstance(value, int):
        return value
    if isinstance(value, str):
        return f"uuid-{uuids.setdefault(value, len(uuids))}" if _UUID.match(value) else value
    if isinstance(value, (bytes, bytearray)):
        return {"bytes_sha256": hashlib.sha256(value).hexdigest()}
    if isinstance(value, tuple):  # a msgpack ext: (type, data)
        return {"ext": value[0], "data": _normalised(value[1], uuids)}
    if isinstance(value, dict):
        return {str(k): _normalised(v, uuids) for k, v in value.items()}
    return [_normalised(v, uuids) for v in value]


def _last_frames(animation: dict) -> dict:
    """A set_animation command reduced to what a picture taken after the playback shows: its
    options, and per animated path its frame rate, its last key time and its last values."""
    out = {"options": animation.get("options"), "paths": {}}
    for entry in animation.get("animations", []):
        clip = entry["clip"]
        out["paths"][entry["path"]] = {
            "fps": clip["fps"],
            "tracks": {
                t["name"]: {"last_time": t["keys"][-1]["time"], "last": t["keys"][-1]["value"]}
                for t in clip["tracks"]
                if t["keys"]
            },
        }
    return out


def _animation_seconds(commands: list[dict]) -> float:
    longest = 0.0
    for c in commands:
        if c.get("type") == "set_animation":
            for entry in c.get("animations", []):
                fps = entry["clip"]["fps"]
                for t in entry["clip"]["tracks"]:
                    if t["keys"]:
                        longest = max(longest, t["keys"][-1]["time"] / fps)
    return longest


def camera_of(commands: list[dict]) -> dict:
    """The camera a recording opens on, in W (m): Meshcat takes it in three.js's y-up frame,
    (x, z, -y) of W."""

    def to_w(v):
        return [float(v[0]), -float(v[2]), float(v[1])] if v is not None else None

    position = target = None
    for c in commands:
        if c.get("type") == "set_property" and c.get("path", "").startswith("/Cameras/default"):
            if c.get("property") == "position":
                position = c["value"]
        elif c.get("type") == "set_target":
            target = c["value"]
    return {"position_W_m": to_w(position), "target_W_m": to_w(target)}


def scene_digest(html: str, window: tuple[int, int]) -> dict:
    """What a screenshot of the recording `html` in a `window` (px) shows, as a digest of its
    normalised scene commands (module docstring), with the camera and the command counts
    beside it for a person to read."""
    commands = scene_commands(html)
    reduced = [_last_frames(c) if c.get("type") == "set_animation" else c for c in commands]
    uuids: dict = {}
    normal = [_normalised(c, uuids) for c in reduced]
    text = json.dumps({"window_px": list(window), "commands": normal}, sort_keys=True)
    counts: dict = {}
    for c in commands:
        counts[c.get("type")] = counts.get(c.get("type"), 0) + 1
    camera = camera_of(commands)
    return {
        "window_px": list(window),
        "camera": {k: [round(x, DIGITS) + 0.0 for x in v] if v else v for k, v in camera.items()},
        "playback_s": round(_animation_seconds(commands), 3),
        "commands": dict(sorted(counts.items())),
        "scene_sha256": hashlib.sha256(text.encode()).hexdigest(),
    }


# -- Chromium ---------------------------------------------------------------------------------


def find_chromium() -> str:
    """The headless browser the screenshots are taken with; a RuntimeError that says how to
    install it when there is none."""
    for name in CHROMIUM_NAMES:
        path = shutil.which(name)
        if path:
            return path
    raise EnvironmentProblem(
        "taking the screenshots needs headless Chromium on PATH (chromium, chromium-browser or "
        "google-chrome; Debian/Ubuntu: apt-get install chromium); checking the committed ones "
        "(check=True, --check) needs none"
    )


def take_screenshot(html_path: Path, png_path: Path, window: tuple[int, int], wait_s: float):
    """Opens `html_path` in headless Chromium (software WebGL) and writes what it shows after
    `wait_s` of (virtual) time to `png_path`."""
    browser = find_chromium()
    with tempfile.TemporaryDirectory(prefix="drake-tooluse-chromium-") as profile:
        shot = Path(profile) / "shot.png"
        args = [
            browser,
            "--headless=new",
            "--no-sandbox",  # root in containers and CI
            "--disable-gpu",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--hide-scrollbars",
            "--no-first-run",
            f"--user-data-dir={profile}",
            f"--window-size={window[0]},{window[1]}",
            f"--virtual-time-budget={int(wait_s * 1000)}",
            f"--screenshot={shot}",
            Path(html_path).resolve().as_uri(),
        ]
        try:
            done = subprocess.run(args, capture_output=True, text=True, timeout=CHROMIUM_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise EnvironmentProblem(
                f"Chromium took over {CHROMIUM_TIMEOUT_S} s on {html_path}"
            ) from None
        if done.returncode != 0 or not shot.is_file():
            tail = (done.stderr or "").strip().splitlines()[-1:] or ["no output"]
            raise EnvironmentProblem(
                f"Chromium made no screenshot (exit {done.returncode}): {tail[0]}"
            )
        return atomic_write_bytes(png_path, shot.read_bytes())


# -- the figures ------------------------------------------------------------------------------


def render_all(figures_dir, check: bool = False, names=None) -> dict:
    """Writes (or with `check`, compares) each screenshot `<name>.png` and its `<name>.json` in
    `figures_dir` (the checkout's docs/figures). `check` needs no browser: it rebuilds each
    recording and compares its scene digest with the one recorded beside the PNG; a
    ValueError names the first that differs."""
    figures_dir = Path(figures_dir)
    if not figures_dir.is_dir():
        raise FileNotFoundError(
            f"{str(figures_dir)!r} is not a folder (the checkout's docs/figures: run from the "
            "checkout)"
        )
    names = list(SCREENSHOTS) if names is None else list(names)
    unknown = [n for n in names if n not in SCREENSHOTS]
    if unknown:
        raise ValueError(f"unknown screenshot {unknown[0]!r}; there are {sorted(SCREENSHOTS)}")
    rerun = "run `drake-tooluse dev render-figures`"
    if check:  # before any simulation
        for name in names:
            png, meta_path = figures_dir / f"{name}.png", figures_dir / f"{name}.json"
            if not png.is_file() or not meta_path.is_file():
                raise ValueError(f"{png} or its {meta_path.name} is missing; {rerun}")
    else:
        find_chromium()  # before any simulation
    out = {}
    for name in names:
        shot = SCREENSHOTS[name]
        png, meta_path = figures_dir / f"{name}.png", figures_dir / f"{name}.json"
        with tempfile.TemporaryDirectory(prefix="drake-tooluse-recording-") as tmp:
            html = shot.record(Path(tmp) / f"{name}.html")
            digest = scene_digest(Path(html).read_text(), shot.window)
            if check:
                recorded = json.loads(meta_path.read_text())
                for key in ("scene_sha256", "window_px", "camera", "playback_s"):
                    if recorded.get(key) != digest[key]:
                        raise ValueError(
                            f"{png} is out of date (its {key} differs from a fresh "
                            f"recording's); {rerun}"
                        )
                out[name] = {"current": True}
                continue
            take_screenshot(Path(html), png, shot.window, digest["playback_s"] + SETTLE_MS / 1000)
        meta = {
            "figure": png.name,
            "made_by": "drake-tooluse dev render-figures",
            "recording": shot.command,
            **digest,
        }
        atomic_write_json(meta_path, meta)
        out[name] = {
            "png": str(png),
            "json": str(meta_path),
            "scene_sha256": digest["scene_sha256"],
        }
    return out
