"""`drake-tooluse record-video`: one episode of a policy as an animated GIF a README or a page can show.

The frames are the env's `rgb_array` renders (`tasks.push.env.ToolPushEnv.render`: the scene
camera framing robot, tool, table, box and goal, the goal drawn on the image), one after the
reset and one after every `every`-th control step, played at the env's rate over `every`.
The GIF shares one palette of `colors` colours over all frames, undithered: the background
then stays the same bytes from frame to frame, and Pillow stores only what changes (an
episode of 100 steps at 480 x 360 is a few hundred KB).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
from PIL import Image

from drake_tooluse.files import atomic_write_bytes, check_output_file
from drake_tooluse.learning.evaluate import make_policy_env, run_episode
from drake_tooluse.limits import MAX_COLORS, MAX_FRAME_STEP
from drake_tooluse.progress import progress_bar
from drake_tooluse.validation import check_int, check_seed

HOLD_LAST_S = 1.5  # s the last frame stays before the GIF loops: the push's end, readable


def record_video(
    policy_dir,
    out,
    seed: int = 0,
    every: int = 2,
    colors: int = 96,
    env_kwargs: dict | None = None,
    trust_pickle: bool = False,
    progress: bool = False,
) -> dict:
    """Runs one deterministic episode of the policy in `policy_dir` from `reset(seed=seed)`
    (to its step limit, as `evaluate`)
    and writes it to `out` (.gif). `env_kwargs` go over the policy's own (e.g. `render_size`,
    `render_camera_position`, `render_camera_target`); `render_mode` is "rgb_array". Returns
    the file, its frames and size, and the episode's figures (the task's metrics).
    `progress`: a bar of the episode's steps where stderr is a terminal."""
    out = check_output_file(out, "out", ".gif")
    check_seed(seed, "seed")
    check_int(every, 1, MAX_FRAME_STEP, "every")
    check_int(colors, 2, MAX_COLORS, "colors")
    kwargs = {**(env_kwargs or {}), "render_mode": "rgb_array"}
    policy, env = make_policy_env(policy_dir, env_kwargs=kwargs, trust_pickle=trust_pickle)
    task_env = type(env.unwrapped)
    frames = []
    limit = env.spec.max_episode_steps if env.spec and env.spec.max_episode_steps else None
    bar = progress_bar(limit, "steps", "step", enabled=progress)  # (a terminal's stderr only)

    def keep(step: int, info) -> None:
        bar.update(step > 0)  # (step 0 is the reset)
        if step % every == 0:
            frames.append(env.render())

    try:
        with bar:
            info, steps = run_episode(env, policy, seed, on_step=keep)
        if steps % every:  # the last state always shown
            frames.append(env.render())
        fps = env.unwrapped.metadata.get("render_fps", 25) / every
    finally:
        env.close()
    data = gif_bytes(frames, fps, colors)
    atomic_write_bytes(out, data)
    h, w = frames[0].shape[:2]
    return {
        "video": str(out),
        "policy": str(Path(policy_dir)),
        "seed": seed,
        "frames": len(frames),
        "fps": fps,
        "size_px": [w, h],
        "bytes": len(data),
        "steps": steps,
        "success": bool(info["is_success"]) and not info.get("sim_error", False),
        "object_name": task_env.TASK.object_name,
        **{m.name: m.read(info) for m in task_env.EPISODE_METRICS},
    }


def gif_bytes(frames, fps: float, colors: int = 96) -> bytes:
    """`frames` ((H, W, 3) uint8, all one size) as a looping GIF at `fps`, the last frame held
    HOLD_LAST_S: one palette of `colors` colours (the median cut of the first and last frames
    side by side), no dithering."""
    if not frames:
        raise ValueError("no frames to write")
    frames = [np.ascontiguousarray(f[:, :, :3], dtype=np.uint8) for f in frames]
    if any(f.shape != frames[0].shape for f in frames):
        raise ValueError(f"the frames differ in size; the first is {frames[0].shape}")
    both = Image.fromarray(np.concatenate([frames[0], frames[-1]], axis=1))
    palette = both.quantize(colors=colors, method=Image.Quantize.MEDIANCUT)
    images = [
        Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE) for f in frames
    ]
    frame_ms = round(1000 / fps)
    durations = [frame_ms] * (len(images) - 1) + [max(frame_ms, round(HOLD_LAST_S * 1000))]
    buffer = io.BytesIO()
    images[0].save(
        buffer,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=durations,
        loop=0,
        optimize=False,  # (one palette already; Pillow still stores only what changes)
        disposal=1,
    )
    return buffer.getvalue()
