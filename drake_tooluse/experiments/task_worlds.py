"""The tasks that use tools of a kind, their worlds and their tools, as the task packages
declare them (`tasks.contract.ToolTask`): what `choose-tool` and `transfer` share.

A tool is written `straight:L` (m) or `hook:HANDLE,HOOK,ANGLE` (m, m, deg) (`robot.tool.parse_tool`,
`robot.tool.tool_label`). A task's worlds (`task_scenarios`): its nominal world with its goal, and
reality as it declares it: `diagrams/reality.yaml` with the task's goal, or the task's world with
what reality changes (actuation delay, conservative joint limits, camera noise: `pull_reality`). The
head camera measures a tool by its kind (`measure`); a generated tool by its shape.
"""

from __future__ import annotations

import dataclasses as dc

from drake_tooluse.builders.hook_measurement import measure_hook_belief
from drake_tooluse.builders.measurement import measure_belief
from drake_tooluse.builders.shape_measurement import measure_shape_belief
from drake_tooluse.paths import REALITY_SCENARIO, SCENARIOS_DIR
from drake_tooluse.robot.tool import HookTool
from drake_tooluse.robot.tool_generator import GeneratedTool
from drake_tooluse.tasks.contract import tool_tasks
from drake_tooluse.validation import check_one_of
from drake_tooluse.world.scenario import Scenario, load_scenario, validate_scenario, with_tool

# The tasks that use tools of a kind, as their tasks declare them (`tasks.contract.ToolTask`).
TOOL_TASKS = tool_tasks()
TASKS = tuple(TOOL_TASKS)


def pull_reality(pull: Scenario, reality: Scenario) -> Scenario:
    """The pull world as reality meets it: `pull` with reality's actuation delay,
    conservative joint limits and camera noise."""
    return validate_scenario(
        dc.replace(
            pull,
            control=dc.replace(pull.control, actuation_delay=reality.control.actuation_delay),
            robot=dc.replace(pull.robot, conservative_limits=reality.robot.conservative_limits),
            camera=dc.replace(pull.camera, noise_sigma=reality.camera.noise_sigma),
        )
    )


def task_scenarios(task: str) -> tuple[Scenario, Scenario]:
    """(nominal, reality) scenarios of a task (a name of TASKS), before any tool or draw: its
    world with its goal, and reality as its task declares it (`ToolTask.reality_world`)."""
    declared = TOOL_TASKS[check_one_of(task, TASKS, "task")]
    reality = load_scenario(REALITY_SCENARIO)
    nominal = load_scenario(SCENARIOS_DIR / declared.world)
    goal = list(nominal.goal_offset)
    goal[1] += declared.goal_extra
    nominal = dc.replace(nominal, goal_offset=goal)
    if not declared.reality_world:
        return nominal, pull_reality(nominal, reality)
    return nominal, dc.replace(reality, goal_offset=goal)


def holding(scenario: Scenario, tool, grasp_along: float | None = None) -> Scenario:
    """`scenario` with `tool` in the hand (and, if given, held `grasp_along` m along it)."""
    s = with_tool(scenario, tool)
    if grasp_along is not None:
        s = validate_scenario(
            dc.replace(s, tool=dc.replace(s.tool, grasp_offset_along=grasp_along))
        )
    return s


def measure(
    reality: Scenario, tool, seed: int, save_images_dir=None, use_grasp_estimate: bool = True
):
    """(what the robot believes of `tool`, held in `reality`, after the head camera measures
    it; the measurement): the straight tool's or the hook's measurement, by the tool's kind.
    With `use_grasp_estimate` the robot holds the tool where the camera saw the grasp along
    it; without, at the nominal grasp (the paper's measurement: the tool's size only). A
    generated tool (`robot.tool_generator.GeneratedTool`) is measured by its shape
    (`measure_shape_belief`: family, shape and grasp together). With `save_images_dir`, the
    annotated views are written there."""
    if isinstance(tool, GeneratedTool):
        if not use_grasp_estimate:
            raise ValueError(
                "a generated tool's frames are measured with its grasp: use_grasp_estimate=False "
                "is for a rod or a hook"
            )
        return measure_shape_belief(reality, save_images_dir=save_images_dir, seed=seed)
    measure_kind = measure_hook_belief if isinstance(tool, HookTool) else measure_belief
    return measure_kind(
        reality, save_images_dir=save_images_dir, seed=seed, use_grasp_estimate=use_grasp_estimate
    )
