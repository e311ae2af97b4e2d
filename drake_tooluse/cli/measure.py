"""`measure`: the tool measured with the head camera; `measure-shape`: a tool of unknown shape,
with its depth views; `measure-box`: where the box starts, with the hand camera."""

from __future__ import annotations

import dataclasses as dc
from pathlib import Path

from drake_tooluse.cli.common import add_scenario_args, output_dir_arg, scenario_from_args
from drake_tooluse.perception.markers import LIGHTINGS, METHODS


def cmd_measure(args) -> dict:
    """The result as a dict (see MeasurementResult.as_dict; a hook's: HookMeasurementResult)."""
    from drake_tooluse.builders.measurement import check_images_dir, measure_tool

    if args.save_images is not None:
        output_dir_arg(args.save_images, "--save-images", must_be_new=False)
        check_images_dir(args.save_images, "--save-images")
    scenario = hook_scenario_from_args(args)
    if scenario is not None:
        return cmd_measure_hook(args, scenario)
    scenario = scenario_from_args(args)
    result = measure_tool(
        scenario,
        save_images_dir=args.save_images,
        noise_sigma=args.noise,
        method=args.method,
        lighting=args.lighting,
    )
    return {"scenario": str(args.scenario), **result.as_dict()}


def hook_scenario_from_args(args):
    """The scenario with a hook in the hand when `--tool-kind hook` (or the scenario file's
    tool is a hook), else None. Each hook option is checked against its range here, named."""
    from drake_tooluse.robot.tool import HOOK_ANGLE_RANGE, HOOK_HANDLE_RANGE, HOOK_LENGTH_RANGE
    from drake_tooluse.validation import check_in_range
    from drake_tooluse.world.scenario import load_scenario, validate_scenario

    given = [
        name
        for name, value in (("--hook-length", args.hook_length), ("--hook-angle", args.hook_angle))
        if value is not None
    ]
    if args.tool_kind == "straight":
        if given:
            raise ValueError(f"{given[0]} is a hook's: give --tool-kind hook with it")
        return None
    scenario = load_scenario(args.scenario)
    if args.tool_kind is None and scenario.tool.kind != "hook":
        if given:
            raise ValueError(f"{given[0]} is a hook's: give --tool-kind hook with it")
        return None
    if args.method != "depth":
        raise ValueError(f"--method={args.method!r} measures a straight tool; a hook: 'depth'")
    tool = dc.replace(scenario.tool, kind="hook", attached=True, model="")
    for option, value, field, (lo, hi), unit in (
        ("--tool-length", args.tool_length, "length", HOOK_HANDLE_RANGE, "m"),
        ("--hook-length", args.hook_length, "hook_length", HOOK_LENGTH_RANGE, "m"),
        ("--hook-angle", args.hook_angle, "hook_angle", HOOK_ANGLE_RANGE, "°"),
    ):
        if value is not None:
            name = f"{option} (the hook's handle)" if field == "length" else option
            tool = dc.replace(tool, **{field: check_in_range(value, lo, hi, name, unit=unit)})
    return validate_scenario(dc.replace(scenario, tool=tool))


def cmd_measure_hook(args, scenario) -> dict:
    """A hook's measurement as a dict (see HookMeasurementResult.as_dict)."""
    from drake_tooluse.builders.hook_measurement import measure_hook

    result = measure_hook(
        scenario,
        save_images_dir=args.save_images,
        noise_sigma=args.noise,
        lighting=args.lighting,
    )
    return {"scenario": str(args.scenario), "tool_kind": "hook", **result.as_dict()}


def format_hook_measurement(out: dict) -> str:
    """Human-readable lines of `cmd_measure_hook`'s dict."""

    def mm(x):
        return float("nan") if x is None else x * 1e3

    def deg(x):
        return float("nan") if x is None else x

    s, t = out["spread"], out["truth"]
    views = len(out["views"]) - len(out["dropped"])
    lines = [
        f"hook: handle {mm(out['handle_length_m']):.2f} mm, hook {mm(out['hook_length_m']):.2f} mm "
        f"at {deg(out['angle_deg']):.2f} deg; held {mm(out['grasp_along_m']):+.2f} mm along the "
        f"handle from the gripper frame's origin ({views} views)",
        f"spread over the views: handle {mm(s['handle_length_m']):.2f} mm, hook "
        f"{mm(s['hook_length_m']):.2f} mm, angle {deg(s['angle_deg']):.2f} deg, grasp "
        f"{mm(s['grasp_along_m']):.2f} mm",
        f"the scenario's: handle {mm(t['handle_length_m']):.1f} mm, hook "
        f"{mm(t['hook_length_m']):.1f} mm at {deg(t['angle_deg']):.1f} deg, grasp "
        f"{mm(t['grasp_along_m']):+.1f} mm",
    ]
    lines += [f"dropped {d['view']}: {d['reason']}" for d in out["dropped"]]
    lines.append(f"{out['wall_time_s']:.2f} s ({out['sim_time_s']:.1f} s simulated)")
    lines += [f"image: {p}" for p in out["image_files"]]
    return "\n".join(lines)


def cmd_measure_shape(args) -> dict:
    """A tool of unknown shape measured: the family named, its parameters, the grasp, the
    working frames in G, and (for comparison) the truth's family and each frame's error."""
    from drake_tooluse.builders.shape_measurement import measure_shape
    from drake_tooluse.robot.tool_generator import FAMILIES, generate_tool
    from drake_tooluse.systems.camera import check_depth_noise
    from drake_tooluse.validation import check_one_of, check_seed
    from drake_tooluse.world.scenario import with_tool

    check_depth_noise(args.depth_noise, "--depth-noise")
    scenario = scenario_from_args(args)
    if args.family is not None:
        family = check_one_of(args.family, tuple(FAMILIES), "--family")
        seed = check_seed(0 if args.tool_seed is None else args.tool_seed, "--tool-seed")
        scenario = with_tool(scenario, generate_tool(family, seed))
    elif args.tool_seed is not None:
        raise ValueError("--tool-seed draws a generated tool: give --family with it")
    result = measure_shape(
        scenario,
        noise_sigma=args.noise,
        depth_noise_sigma=args.depth_noise,
        lighting=args.lighting,
    )
    return {"scenario": str(args.scenario), **result.as_dict()}


def format_shape_measurement(out: dict) -> str:
    """Human-readable lines of `cmd_measure_shape`'s dict."""
    params = ", ".join(
        f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in out["params"].items()
    )
    lines = [
        f"family: {out['family']} (the scenario's: {out['truth_family']}); "
        f"{out['points']} points, {out['rms_m'] * 1e3:.2f} mm RMS from the fitted {out['fitted_family']}",
        f"parameters: {params}",
        f"grasp: {out['grasp_across_m'] * 1e3:+.1f} mm across, {out['grasp_along_m'] * 1e3:+.1f} mm "
        "along (a handle held deeper looks the same as a shorter one: the frames in G tell)",
    ]
    errors = out["frame_errors_m"]
    for name, p in out["frames_G_m"].items():
        error = f"; {errors[name] * 1e3:.2f} mm from the scenario's" if name in errors else ""
        lines.append(
            f"{name}: ({', '.join(f'{v * 1e3:.1f}' for v in p)}) mm in the gripper frame{error}"
        )
    lines += [f"dropped {d['view']}: {d['reason']}" for d in out["dropped"]]
    lines.append(f"capture {out['capture_time_s']:.1f} s, fit {out['fit_time_s']:.1f} s")
    return "\n".join(lines)


def cmd_measure_box(args) -> dict:
    """The box's start as the hand camera measures it, beside the scenario's truth."""
    from drake_tooluse.builders.box_measurement import measure_box_start
    from drake_tooluse.world.scene import initial_box_pose

    scenario = scenario_from_args(args)
    measured = measure_box_start(scenario)
    truth = initial_box_pose(scenario).translation()
    return {
        "scenario": str(args.scenario),
        "box_xy_m": measured.p_WB_xy.tolist(),
        "top_z_m": measured.top_z,
        "top_face_points": measured.points,
        "truth_xy_m": truth[:2].tolist(),
        "error_m": float(((measured.p_WB_xy - truth[:2]) ** 2).sum() ** 0.5),
    }


def format_box_measurement(out: dict) -> str:
    """Human-readable line of `cmd_measure_box`'s dict."""
    x, y = out["box_xy_m"]
    return (
        f"box centre at x {x:.4f} m, y {y:.4f} m, top face {out['top_z_m']:.4f} m "
        f"({out['top_face_points']} points); the scenario's {out['error_m'] * 1e3:.2f} mm away"
    )


def format_measurement(out: dict) -> str:
    """Human-readable lines of `cmd_measure`'s dict (for the CLI without --json)."""
    if out.get("tool_kind") == "hook":
        return format_hook_measurement(out)
    mm = {k: (v * 1e3 if v is not None else float("nan")) for k, v in out["per_view_m"].items()}
    lines = [
        f"tool length {out['tool_length_m'] * 1e3:.2f} mm ({out['method']} variant; "
        f"spread {out['spread_m'] * 1e3:.2f} mm over "
        f"{len(out['views']) - len(out['dropped'])} views; pixel variant "
        f"{(out['length_pixel_m'] or float('nan')) * 1e3:.2f} mm)",
        "per view: " + ", ".join(f"{k} {v:.2f} mm" for k, v in mm.items()),
    ]
    if out.get("grasp_along_m") is not None:
        lines.append(
            f"held {out['grasp_along_m'] * 1e3:+.2f} mm along the tool from the "
            "gripper frame's origin (the grasp point)"
        )
    lines += [f"dropped {d['view']}: {d['reason']}" for d in out["dropped"]]
    lines.append(f"{out['wall_time_s']:.2f} s ({out['sim_time_s']:.1f} s simulated)")
    lines += [f"image: {p}" for p in out["image_files"]]
    return "\n".join(lines)


def add_parsers(sub) -> None:
    p = sub.add_parser(
        "measure",
        help="measure the tool with the head camera (OpenCV + depth): a straight tool's length "
        "(three views), a hook's handle, hook and angle (five views; --tool-kind hook)",
    )
    add_scenario_args(p)
    p.add_argument(
        "--save-images",
        type=Path,
        metavar="DIR",
        help="write each view annotated as DIR/measure_<view>.png, all of them at once in "
        "place of the views there (DIR holds nothing else)",
    )
    p.add_argument(
        "--noise",
        type=float,
        metavar="SIGMA",
        help="Gaussian colour noise, grey levels (default: the scenario's)",
    )
    p.add_argument(
        "--method",
        default="depth",
        choices=list(METHODS),
        help="depth: back-project with the depth image (default); pixel: the "
        "paper's fixed metres per pixel",
    )
    p.add_argument(
        "--lighting", default="default", choices=list(LIGHTINGS), help="renderer lighting"
    )
    p.add_argument(
        "--tool-kind",
        choices=["straight", "hook"],
        help="the tool in the hand (default: the scenario's); hook: its handle length, hook "
        "length and angle and the grasp along the handle are measured, --tool-length is the "
        "handle's (m, in [0.15, 0.35])",
    )
    p.add_argument(
        "--hook-length", type=float, metavar="M", help="the hook's length (m, in [0.03, 0.08])"
    )
    p.add_argument(
        "--hook-angle",
        type=float,
        metavar="DEG",
        help="the hook's angle to the handle (degrees, in [60, 120]; 90: an L)",
    )
    p.set_defaults(run=cmd_measure, show=format_measurement)
    p = sub.add_parser(
        "measure-shape",
        help="measure a tool the robot was not told about with the head camera's depth views: "
        "its family (or other), shape, grasp and working frames",
    )
    add_scenario_args(p)
    p.add_argument(
        "--family",
        metavar="FAMILY",
        help="hold the generator's tool of this family (with --tool-seed; default: the "
        "scenario's tool)",
    )
    p.add_argument(
        "--tool-seed", type=int, metavar="S", help="the generated tool's seed (default 0)"
    )
    p.add_argument(
        "--noise", type=float, metavar="SIGMA", help="Gaussian colour noise, grey levels"
    )
    p.add_argument(
        "--depth-noise",
        type=float,
        default=0.0,
        metavar="M",
        help="Gaussian depth noise, m (in [0, 0.01]; default 0)",
    )
    p.add_argument(
        "--lighting", default="default", choices=list(LIGHTINGS), help="renderer lighting"
    )
    p.set_defaults(run=cmd_measure_shape, show=format_shape_measurement)
    p = sub.add_parser(
        "measure-box",
        help="measure where the box starts with the camera on the robot's hand (depth, OpenCV)",
    )
    add_scenario_args(p)
    p.set_defaults(run=cmd_measure_box, show=format_box_measurement)
