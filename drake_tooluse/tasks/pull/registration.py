"""Gymnasium registration of the pull env; imports nothing heavy (no pydrake)."""

from drake_tooluse.tasks.contract import (
    TaskDeclaration,
    ToolTask,
    register_task_envs,
    register_tool_tasks,
)

# No tool-tip trajectory to replay (so no open-loop transfer), no distillation; not the
# paper's figures.
TASK = TaskDeclaration(
    "pull",
    "cube",
    frozenset({"record-video", "evaluate --meshcat", "transfer"}),
    scripted="drake_tooluse.tasks.pull.scripted:ScriptedPull",
)

MAX_EPISODE_STEPS = 100
# Of the generated tools, those the hook policy pulls with as their equivalent hook (corner to
# tip): the hooks and the arcs (11 of 12 arcs in the nominal world, 12 of 12 in reality). A
# rake's crossbar lands on the cube as it comes down (1 of 12).
SHAPE_FAMILIES = ("hook", "arc")
ENV_IDS = {"drake_tooluse/ToolPull-v1": {}}
# The task the robot chooses a tool for: a hook pulls the cube; reality is the pull world with
# reality's actuation delay, joint limits and camera noise.
TOOL_TASKS = (
    ToolTask(
        "pull",
        "drake_tooluse/ToolPull-v1",
        "ppo_toolpull",
        "hook",
        "pull.yaml",
        "the pull's control acts on a hook's inner corner, which a straight tool lacks",
        "hook:0.25,0.05,75",
        reality_world=False,
        # The demo's hook and the rack's L-hook: two geometries of the ranges it trained over.
        transfer_tools=("hook:0.25,0.05,75", "hook:0.25,0.05,90"),
        shape_families=SHAPE_FAMILIES,
        shapes_policy="ppo_toolpull_shapes",
    ),
)


def register_envs() -> None:
    """Registers the ids (idempotent); `gym.make` builds them lazily."""
    register_task_envs(ENV_IDS, "drake_tooluse.tasks.pull.env:ToolPullEnv", MAX_EPISODE_STEPS, TASK)
    register_tool_tasks(TOOL_TASKS)
