"""Gymnasium registration of the push envs; imports nothing heavy (no pydrake)."""

from drake_tooluse.tasks.contract import (
    COMMAND_NEEDS,
    TaskDeclaration,
    ToolTask,
    register_task_envs,
    register_tool_tasks,
)

# The paper's task: every command serves it.
TASK = TaskDeclaration(
    "push",
    "box",
    frozenset(COMMAND_NEEDS),
    scripted="drake_tooluse.tasks.push.scripted:ScriptedPush",
    scripted_env_kwargs=(("action_mode", "position"),),
)

MAX_EPISODE_STEPS = 100
ENV_IDS = {
    "drake_tooluse/ToolPush-v1": {"reward_type": "tool_and_box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushBoxReward-v1": {"reward_type": "box", "goal_extra": 0.0},
    "drake_tooluse/ToolPushFar-v1": {"reward_type": "tool_and_box", "goal_extra": 0.10},
}
# The tasks the robot chooses a tool for: the paper's push, and the push 0.10 m further.
STRAIGHT_ONLY = "the tool-tip policy is trained on straight tools"
DEMO_TOOL = "straight:0.125"  # the paper's unseen tool (world.paper.DEMO_TOOL_LENGTH)
TOOL_TASKS = (
    ToolTask(
        "push",
        "drake_tooluse/ToolPush-v1",
        "ppo_toolpush_tip",
        "straight",
        "push.yaml",
        STRAIGHT_ONLY,
        DEMO_TOOL,
        shapes_policy="ppo_toolpush_shapes",
    ),
    ToolTask(
        "push-far",
        "drake_tooluse/ToolPushFar-v1",
        "ppo_toolpush_tip_far",
        "straight",
        "push.yaml",
        STRAIGHT_ONLY,
        DEMO_TOOL,
        goal_extra=ENV_IDS["drake_tooluse/ToolPushFar-v1"]["goal_extra"],
        shapes_policy="ppo_toolpush_shapes_far",
    ),
)


def register_envs() -> None:
    """Registers the ids (idempotent); `gym.make` builds them lazily."""
    register_task_envs(ENV_IDS, "drake_tooluse.tasks.push.env:ToolPushEnv", MAX_EPISODE_STEPS, TASK)
    register_tool_tasks(TOOL_TASKS)
