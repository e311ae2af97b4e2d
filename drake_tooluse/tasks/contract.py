"""What every task gives: the contract between a task package and the rest of the project.

A task is one package under `drake_tooluse/tasks/<task>/` (the push task is `tasks.push`). It
gives:

- **wiring** (`TaskParts`): a function that adds the task to a `DiagramBuilder` given the world's
  scenario and the robot's belief, and returns the systems whose ports it exports —
  `observation` (what the policy sees), `reward` (the step's reward) and `success` (1.0 when the
  task is done, else 0.0) — with the tool-tip control whose `action` input a policy drives;
- **envs** (`TaskEnv`): Gymnasium envs, registered on `import drake_tooluse` by the task's
  `registration` module (which imports no Drake), each class able to check its keyword
  arguments and give its spaces without being built;
- **metrics** (`EpisodeMetric`): what an evaluation reports of an episode, read from the last
  step's `info`;
- **physical limits** (`PhysicalLimit`): figures of physical sanity its envs report every step
  in `info` (a penetration, a speed), each with the limit past which the step is flagged there;
  an evaluation counts the episodes with a flagged step, per flag.

A task whose episode has a goal and a box's start (push, pull) builds its pieces from shared
ones, so that what the tasks do the same is written once: its outcome system on
`systems.task_outcome.TaskOutcome` (with its metrics reader on `BoxAndToolPointReader`), its
observation on `systems.goal_observation.GoalObservation`, its wiring through
`GoalTaskParts.wire`, its env class on `builders.task_gym_env.TaskGymEnv`, its keyword
arguments' names checked by `env_config` and its ids registered by `register_task_envs`.

`learning/` trains and evaluates any registered env whose class is a `TaskEnv`: it finds the
class through Gymnasium's registry and imports no task (tests/test_architecture.py checks it).
"""

from __future__ import annotations

import dataclasses
import importlib
import os
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import load_env_creator, parse_env_id

# Every env id of the project lives in this Gymnasium namespace.
ENV_NAMESPACE = "drake_tooluse"
# The env versions no longer registered, each with the git tag whose code runs it and
# reproduces the figures made with it (an env's behaviour changes with its version, never by an
# option: the old figures stay at their tag).
RETIRED_VERSIONS = {0: "figures-v0"}


# What each command needs of a task beyond the contract (an env class following `TaskEnv`:
# `train`, `evaluate`, `sweep`, `study` and `train --init-from` need nothing more). A task's
# `TaskDeclaration.serves` names those it gives; any other command refuses its policies and
# envs before any work, saying what the task lacks (`check_serves`).
COMMAND_NEEDS = {
    "trajectory": "a tool-tip trajectory from the policy's episodes to replay open loop",
    "transfer": "other tools of its kind to run the policy with and a reality to judge them "
    "in (its ToolTask)",
    "distill": "a tool-tip position teacher whose actions a student on the paper's "
    "observation can learn",
    "record-video": "an rgb_array render of its env",
    "evaluate --meshcat": "a Meshcat view of its env",
    "study-report": "the paper's figures (each run's final box–goal distance and success, "
    "beside the paper's table)",
}


@dataclass(frozen=True)
class TaskDeclaration:
    """What a task declares for the commands, in one place: its env classes' `TASK`.

    `name` is the task as commands name it ("push"); `object_name` the word they print for
    what it moves ("box"); `serves` the commands of COMMAND_NEEDS it gives; `scripted` its
    scripted reference, if it has one: the "module:Class" of a controller (made with the
    table top's height, m; called with an observation, giving an action), and
    `scripted_env_kwargs` the env kwargs ((name, value) pairs) whose observation and action it
    uses."""

    name: str
    object_name: str = "object"
    serves: frozenset = frozenset()
    scripted: str | None = None
    scripted_env_kwargs: tuple = ()


@dataclass(frozen=True)
class ToolTask:
    """A task the robot chooses a tool for (`choose-tool --task NAME`), as its task declares
    it (`register_tool_tasks`): what `experiments.tool_choice` needs, with no test of a task's
    name there.

    `env_id`: the env whose policy does it; `policy`: that policy's directory name under
    models/policies; `tool_kind`: the kind of tool the policy uses ("straight" or "hook"), and
    `why_not` why another kind cannot do it; `world`: its scenario file's name (under
    `paths.SCENARIOS_DIR`); `goal_extra`: m added to the goal along y. `reality_world`: True
    where reality is diagrams/reality.yaml itself (with this task's goal); False where it is
    this task's world with reality's actuation delay, joint limits and camera noise.
    `demo_tool`: the tool `drake-tooluse demo --task NAME` hands the robot (as `choose-tool
    --tools` writes one: "straight:0.125", "hook:0.25,0.05,75"). `transfer_tools`: the tools
    `drake-tooluse transfer` uses by default with its policy, written the same way (none:
    the paper's tool lengths). `shapes_policy`: the policy directory's name for a generated
    tool of any shape (`robot.tool_generator`: trained over its training split); None: the
    task's `policy`, through the tool's tip. `shape_families`: the generator's families the
    policy serves (None: every family, through the tip or the push point; a hook policy's
    tools are held as their `robot.tool_generator.equivalent_hook`)."""

    name: str
    env_id: str
    policy: str
    tool_kind: str
    world: str
    why_not: str
    demo_tool: str
    goal_extra: float = 0.0
    reality_world: bool = True
    transfer_tools: tuple = ()
    shapes_policy: str | None = None
    shape_families: tuple | None = None


# The declarations of the registered ids (`register_task_envs`), and the tool-choice tasks
# (`register_tool_tasks`), by name.
_DECLARATIONS: dict = {}
_TOOL_TASKS: dict = {}


def register_tool_tasks(tasks) -> None:
    """Declares each `ToolTask` of `tasks` (by its name; idempotent)."""
    for task in tasks:
        _TOOL_TASKS[task.name] = task


def tool_tasks() -> dict:
    """The declared tool-choice tasks, {name: ToolTask}, in the order they were declared."""
    return dict(_TOOL_TASKS)


def tool_task_of(env_id: str):
    """The declared tool task whose policy acts in `env_id` (`ToolTask.env_id`), or None."""
    return next((t for t in _TOOL_TASKS.values() if t.env_id == env_id), None)


def register_task_envs(
    env_ids: dict, entry_point: str, max_episode_steps: int, task: TaskDeclaration | None = None
) -> None:
    """Registers each id of `env_ids` ({id: its keyword arguments}) with Gymnasium, made by
    `entry_point` ("module:Class") and truncated at `max_episode_steps` (idempotent: an id
    already registered is left as it is); `gym.make` builds them lazily. `task`: what the
    task declares for the commands (read without importing the env's module)."""
    for env_id, kwargs in env_ids.items():
        if task is not None:
            _DECLARATIONS[env_id] = task
        if env_id not in gym.registry:
            gym.register(
                env_id,
                entry_point=entry_point,
                max_episode_steps=max_episode_steps,
                kwargs=dict(kwargs),
                # Gymnasium 1.4's PassiveEnvChecker breaks every later step of an env whose
                # first reset raised (a refused seed): docs/UPSTREAM.md. The envs pass
                # Gymnasium's full `check_env` in the tests instead.
                disable_env_checker=True,
            )


# A task written in a module of its own, outside the package (docs/ARCHITECTURE.md's "Add a
# task"), is known to every process of the project (the study's and the sweep's subprocesses
# included) by naming its module here: comma-separated modules, each registering its ids when
# imported.
TASK_MODULES_VARIABLE = "DRAKE_TOOLUSE_TASKS"
_imported_task_modules: set = set()


def import_task_modules() -> None:
    """Imports each module DRAKE_TOOLUSE_TASKS names, once; one that is no dotted module name,
    or whose import fails in any way, is a ValueError naming it, why and the variable."""
    value = os.environ.get(TASK_MODULES_VARIABLE, "")
    for name in (n.strip() for n in value.split(",")):
        if not name or name in _imported_task_modules:
            continue
        if not all(part.isidentifier() for part in name.split(".")):
            raise ValueError(
                f"{TASK_MODULES_VARIABLE}={value!r}: {name!r} is not a module name "
                "(dotted Python identifiers, as `import` takes)"
            )
        _imported_task_modules.add(name)  # a module that asks for the ids while it imports
        try:
            importlib.import_module(name)
        except Exception as e:  # (a module's own error too: a task module is user code)
            _imported_task_modules.discard(name)
            raise ValueError(
                f"{TASK_MODULES_VARIABLE}={value!r}: cannot import the task module {name!r} "
                f"({type(e).__name__}: {e})"
            ) from None


def task_env_ids() -> list[str]:
    """The registered ids of the project's namespace (registered on `import drake_tooluse`,
    and by the task modules of DRAKE_TOOLUSE_TASKS)."""
    import_task_modules()
    return [i for i in gym.registry if i.startswith(ENV_NAMESPACE + "/")]


def check_env_id(env_id) -> str:
    """`env_id`, registered; else a ValueError naming it and the registered ids or, for an
    earlier version of a registered id, the git tag that runs it."""
    ids = task_env_ids()
    if isinstance(env_id, str) and env_id in ids:
        return env_id
    retired = retired_version(env_id) if isinstance(env_id, str) else None
    if retired is not None:
        tag, current = retired
        raise ValueError(
            f"{env_id!r} is an earlier version of {current!r}, no longer registered: it and its "
            f"figures are reproducible at git tag {tag} (git checkout {tag})"
        )
    raise ValueError(f"unknown env {env_id!r}; choose one of {ids}")


def retired_version(env_id: str) -> tuple[str, str] | None:
    """(the git tag that runs it, the registered id of its env) where `env_id` is an earlier
    version of a registered id (`RETIRED_VERSIONS`), else None."""
    try:
        namespace, name, version = parse_env_id(env_id)
    except gym.error.Error:
        return None
    if namespace != ENV_NAMESPACE or version not in RETIRED_VERSIONS:
        return None
    current = [i for i in task_env_ids() if parse_env_id(i)[:2] == (namespace, name)]
    return (RETIRED_VERSIONS[version], current[-1]) if current else None


def env_class(env_id: str) -> type[TaskEnv]:
    """The class a registered id makes (its module imported on first use)."""
    entry_point = gym.spec(check_env_id(env_id)).entry_point
    cls = load_env_creator(entry_point) if isinstance(entry_point, str) else entry_point
    if not (isinstance(cls, type) and issubclass(cls, TaskEnv)):
        raise ValueError(f"env {env_id!r} ({entry_point!r}) does not follow the task contract")
    return cls


def declaration(env_id: str) -> TaskDeclaration:
    """What `env_id`'s task declares: as registered (`register_task_envs`, no env module
    imported), else its env class's `TASK`."""
    task = _DECLARATIONS.get(check_env_id(env_id))
    return task if task is not None else env_class(env_id).TASK


def scripted_reference(env_id: str, table_top_z: float):
    """(controller, env kwargs) of `env_id`'s task's scripted reference
    (`TaskDeclaration.scripted`); a ValueError names a task that has none."""
    task = declaration(env_id)
    if task.scripted is None:
        raise ValueError(f"the {task.name} task ({env_id}) declares no scripted reference")
    controller = load_env_creator(task.scripted)(table_top_z)
    return controller, dict(task.scripted_env_kwargs)


def check_serves(env_id: str, command: str) -> TaskDeclaration:
    """The declaration of `env_id`'s task, where its task serves `command` (a key of
    COMMAND_NEEDS); else a ValueError naming the command, what it needs and the task."""
    task = declaration(env_id)
    if command not in task.serves:
        serves = ", ".join(sorted(task.serves)) or "only train, evaluate, sweep and study"
        raise ValueError(
            f"{command} needs {COMMAND_NEEDS[command]}, which the {task.name} task "
            f"({env_id}) does not give; it serves: {serves}"
        )
    return task


@dataclass(frozen=True)
class EpisodeMetric:
    """One figure of an episode, read from its last step's `info[info_key]`.

    A number with a unit suffix (`name` "final_object_to_goal_m") is summarized over episodes as
    mean, median and std ("final_object_to_goal_mean_m", …) or as its mean alone (`mean_only`);
    a flag (`flag`) as the rate of episodes it was true in ("tool_touched_rate")."""

    name: str
    info_key: str
    flag: bool = False
    mean_only: bool = False

    def summary(self, values) -> dict:
        """The summary of this metric's per-episode `values`."""
        if self.flag:
            return {f"{self.name}_rate": float(np.mean(values))}
        base, _, unit = self.name.rpartition("_")
        stats = (
            {"mean": np.mean}
            if self.mean_only
            else {
                "mean": np.mean,
                "median": np.median,
                "std": np.std,
            }
        )
        return {f"{base}_{stat}_{unit}": float(f(values)) for stat, f in stats.items()}

    def read(self, info: dict):
        value = info[self.info_key]
        return bool(value) if self.flag else float(value)


@dataclass(frozen=True)
class PhysicalLimit:
    """A figure of physical sanity every step's `info` holds (`info[info_key]`, in `unit`) and
    its limit: where the figure is past `limit`, `info[flag]` is True. `why` says, in one
    line, what a step past it means."""

    flag: str
    info_key: str
    limit: float
    unit: str
    why: str


def env_config(config_class, kwargs: dict, name: str, env: str):
    """`config_class(**kwargs)`: the dataclass of an env's keyword arguments (`env` names the
    env in an error), the names checked: one it has no field for is a ValueError naming it,
    `name` (where they came from) and the allowed names. Their values are the caller's to
    check."""
    allowed = [f.name for f in dataclasses.fields(config_class)]
    unknown = sorted(set(kwargs) - set(allowed))
    if unknown:
        raise ValueError(f"unknown argument(s) {unknown} for {env} ({name}); allowed: {allowed}")
    return config_class(**kwargs)


class TaskEnv:
    """The class-level part of a task env's contract (a mixin of the task's env class, which
    is a `pydrake.gym.DrakeGymEnv`). Every step's `info` holds `is_success`, `sim_error` and
    the keys its `EPISODE_METRICS` read, and each of its `PHYSICAL_LIMITS`' figure and flag."""

    # What an evaluation reports of each episode, in order (the first is the headline).
    EPISODE_METRICS: tuple[EpisodeMetric, ...] = ()
    # The physical-sanity figures every step reports, with their limits (an evaluation counts
    # the episodes in which any step was past each).
    PHYSICAL_LIMITS: tuple[PhysicalLimit, ...] = ()
    # What the task gives the commands (`TaskDeclaration`); a task that declares nothing is
    # served by train, evaluate and sweep.
    TASK: TaskDeclaration = TaskDeclaration("unnamed")

    @classmethod
    def add_task(
        cls, builder, scenario, belief=None, kwargs=None, visuals: bool = True
    ) -> TaskParts:
        """The task wired into `builder` as the env these keyword arguments make wires it (its
        control, observation and outcome), in the world of `scenario`, the robot's IK holding
        `belief` (default: the scenario's tool): the task's one builder, which the env is made
        of and a deployed policy runs in (`tasks.deploy`). The tip target's `action` input is
        left unconnected. Without `visuals`, for a world nothing draws or renders, the
        robot has no visual geometry (`world.scene.add_world`). A task whose policies deploy
        nowhere else raises."""
        raise NotImplementedError("this task deploys no policy outside its env")

    @classmethod
    def check_kwargs(cls, kwargs, name: str = "env kwargs") -> dict:
        """The env's keyword arguments, checked (names and values) without building it: an
        unknown name or a bad value is a ValueError naming it. Returns them as a dict."""
        raise NotImplementedError

    @classmethod
    def spaces(cls, kwargs) -> tuple[list, list]:
        """(observation shape, action shape) of the env these keyword arguments make."""
        raise NotImplementedError


@dataclass
class TaskParts:
    """What a task's wiring added to a builder: the world, the robot's IK and the tool-tip
    control (its `target.GetInputPort("action")` is the policy's input), and the output ports
    the task gives: `observation`, `reward` ([r]) and `success` ([1.0] or [0.0])."""

    world: object
    ik: object
    control: object
    observation_port: object
    reward_port: object
    success_port: object

    def export(self, builder) -> None:
        """Exports the task's ports from the diagram under their contract names: the input
        `action` and the outputs `observation`, `reward` and `success`."""
        builder.ExportInput(self.control.target.GetInputPort("action"), "action")
        builder.ExportOutput(self.observation_port, "observation")
        builder.ExportOutput(self.reward_port, "reward")
        builder.ExportOutput(self.success_port, "success")


@dataclass
class GoalTaskParts(TaskParts):
    """The contract's parts of a task whose episode has a goal and an object's start: with the
    two systems that hold them, `observation` (the world plant's state in; `set_goal`) and
    `outcome` (`systems.task_outcome.TaskOutcome`: the plant's body poses and contact results
    in, `reward` and `success` out; `set_episode`)."""

    observation: object = None
    outcome: object = None

    @classmethod
    def wire(cls, builder, world, ik, control, observation, outcome, **parts):
        """Adds `observation` and `outcome` to `builder` under those names, connected to the
        world plant's ports; returns the task's parts (`parts`: a subclass's other fields)."""
        plant = world.plant
        observation = builder.AddNamedSystem("observation", observation)
        builder.Connect(plant.get_state_output_port(), observation.get_input_port())
        outcome = builder.AddNamedSystem("outcome", outcome)
        builder.Connect(plant.get_body_poses_output_port(), outcome.GetInputPort("body_poses"))
        builder.Connect(
            plant.get_contact_results_output_port(), outcome.GetInputPort("contact_results")
        )
        return cls(
            world,
            ik,
            control,
            observation.get_output_port(),
            outcome.GetOutputPort("reward"),
            outcome.GetOutputPort("success"),
            observation=observation,
            outcome=outcome,
            **parts,
        )

    def set_episode(self, root_context, goal, start) -> None:
        """This episode's goal and the object's start (m, W), in both systems."""
        self.observation.set_goal(self.observation.GetMyMutableContextFromRoot(root_context), goal)
        self.outcome.set_episode(
            self.outcome.GetMyMutableContextFromRoot(root_context), goal, start
        )
