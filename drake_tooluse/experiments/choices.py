"""The experiments' option names and defaults, and the transfer's tools, without Drake: the command line
checks them before it imports the modules that use them (`experiments.transfer`,
`experiments.trajectory_extraction`)."""

from __future__ import annotations

from drake_tooluse.robot.tool import (
    HookTool,
    StraightTool,
    check_tool_length,
    parse_tool,
    tool_label,
)
from drake_tooluse.tasks.contract import tool_task_of
from drake_tooluse.world.paper import PAPER_TOOL_LENGTHS

MODES = ("closed-loop", "open-loop")  # a transfer run: the policy in the loop, or a replay
ALIGNMENTS = ("start", "contact")  # averaging episodes from their start or the first touch
# What a recorded trajectory holds at each step: where the tip got (the paper's: with Fetch's
# mocap it is where it was commanded), or the tip pose the step commanded (the IK's joint
# targets). Baxter's arm lags its command by ~2 cm at full speed, so a replay of where the tip
# got commands a slower push that trails the recorded one.
RECORDS = ("achieved", "commanded")
# How the open-loop transfer makes its trajectory of the policy's episodes: the paper's per-step
# mean of where the tip got, replayed as it is; or that of the commanded poses, of each episode
# in its box's frame, the tool tilted into a line contact, and replayed at the box start the
# hand camera measures (`experiments.line_contact`).
EXTRACTIONS = ("line-contact", "mean-achieved")
# A tool choice's rollouts per tool: with 3, tools that succeed about half the time in reality
# (unseen tools on the far push and the pull) were told apart no better than by chance.
DEFAULT_ROLLOUTS = 6
# What each takes by default for the recording (RECORDS).
EXTRACTION_RECORDS = {"line-contact": "commanded", "mean-achieved": "achieved"}
# Randomization draws of the nominal simulation over which a line-contact trajectory is moved
# across the push to where it pushes best (`experiments.line_contact.calibrated`); 0: not.
CALIBRATION_DRAWS = 16


# -- the transfer's tools -------------------------------------------------------------------


def transfer_tool(tool):
    """A tool of the experiment: a straight tool as its length (m), a hook as a `HookTool`;
    from a length, a Tool, or the text `L`, `straight:L` or `hook:HANDLE,HOOK,ANGLE`."""
    if isinstance(tool, str) and ":" in tool:
        tool = parse_tool(tool)
    if isinstance(tool, HookTool):
        return tool
    if isinstance(tool, StraightTool):
        tool = tool.length
    if isinstance(tool, str):
        try:
            tool = float(tool)
        except ValueError:
            raise ValueError(
                f"tool {tool!r} is not a length (m), straight:L or hook:HANDLE,HOOK,ANGLE"
            ) from None
    return check_tool_length(tool, "tool length")


def hook_text(m: dict) -> str:
    return (
        f"handle {m['handle_length_m'] * 1000:.1f} mm, hook {m['hook_length_m'] * 1000:.1f} mm, "
        f"{m['angle_deg']:.1f} deg"
    )


def tool_text(tool) -> str:
    """A tool of the experiment in words: "0.125 m" or "hook:0.25,0.05,90"."""
    return tool_label(tool) if isinstance(tool, HookTool) else f"{tool:.3f} m"


def task_tools(env_id: str) -> tuple:
    """The tools a transfer of `env_id`'s policy uses by default: the tools its task declares
    (`ToolTask.transfer_tools`), else the paper's lengths."""
    task = tool_task_of(env_id)
    return tuple(task.transfer_tools) if task and task.transfer_tools else PAPER_TOOL_LENGTHS


def check_tool_kinds(env_id: str, tools) -> None:
    """Each of `tools` is of the kind `env_id`'s policy uses (`ToolTask.tool_kind`; straight
    where its task declares none); else a ValueError naming the tool."""
    task = tool_task_of(env_id)
    kind = task.tool_kind if task else "straight"
    for tool in tools:
        if ("hook" if isinstance(tool, HookTool) else "straight") != kind:
            why = f" ({task.why_not})" if task else ""
            raise ValueError(
                f"tool {tool_text(tool)}: the policy of {env_id} uses {kind} tools{why}"
            )
