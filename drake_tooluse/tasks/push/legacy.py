"""The push envs' `-v0` ids: the earlier behaviour, kept only while policies trained on it are
shipped. The `-v1` envs (`tasks.push.env.ToolPushEnv`) are the one behaviour; see its
docstring's Version History.

A `-v0` env advances its clock by summing control periods (`TaskGymEnv.DRIFTING_CLOCK`), and
takes four options, each off by default as it was: `end_at_success`, `bound_joint_speed`,
`continuous_quaternion` and `target_from_observed_state`. It also reads the mode names of
earlier policy files ("paper") and their `ik_mode="full"`.
"""

from __future__ import annotations

import dataclasses as dc

from drake_tooluse.builders.control import BEHAVIOUR_V0, BEHAVIOUR_V1, ControlBehaviour
from drake_tooluse.tasks.push.env import EnvConfig, ToolPushEnv
from drake_tooluse.validation import check_bool, check_mapping

# Values earlier versions wrote into policy files and run configurations, read as today's.
LEGACY_VALUES = {
    "action_mode": {"paper": "position_quaternion"},
    "observation_mode": {"paper": "gripper_joints"},
}


def current_kwargs(kwargs: dict) -> dict:
    """`kwargs` with the names of earlier versions replaced by today's: the modes once named
    "paper", and `ik_mode`, a keyword with the one value "full" (the exact IK, always on)."""
    kwargs = dict(kwargs)
    for key, renamed in LEGACY_VALUES.items():
        value = kwargs.get(key)
        if isinstance(value, str) and value in renamed:
            kwargs[key] = renamed[value]
    if "ik_mode" in kwargs:
        if kwargs["ik_mode"] != "full":
            raise ValueError(
                f"ik_mode={kwargs['ik_mode']!r} is retired: the env always runs the exact "
                "tool-tip IK; leave ik_mode out"
            )
        del kwargs["ik_mode"]
    return kwargs


@dc.dataclass
class LegacyEnvConfig(EnvConfig):
    """`EnvConfig` with the `-v0` ids' four options."""

    # Terminate at the first success (the earlier protocol).
    end_at_success: bool = False
    # Bound the joint targets' speed at Baxter's rated joint speeds.
    bound_joint_speed: bool = False
    # `position_quaternion`: add the change in the initial quaternion's hemisphere.
    continuous_quaternion: bool = False
    # Move the tip target from the arm state the policy observed.
    target_from_observed_state: bool = False


class ToolPushEnvV0(ToolPushEnv):
    """The push task as it was at `-v0` (the module docstring)."""

    CONFIG = LegacyEnvConfig
    DRIFTING_CLOCK = True

    @classmethod
    def _config(cls, kwargs, name: str = "env kwargs") -> LegacyEnvConfig:
        config = super()._config(current_kwargs(check_mapping(kwargs, name)), name)
        for option in ("end_at_success", "bound_joint_speed", "continuous_quaternion"):
            check_bool(getattr(config, option), option)
        check_bool(config.target_from_observed_state, "target_from_observed_state")
        return config

    @classmethod
    def check_kwargs(cls, kwargs, name: str = "env kwargs") -> dict:
        super().check_kwargs(kwargs, name)
        return current_kwargs(kwargs or {})

    @classmethod
    def ends_at_success(cls, kwargs) -> bool:
        return cls._config(kwargs).end_at_success

    @classmethod
    def _behaviour_of(cls, config) -> ControlBehaviour:
        return dc.replace(
            BEHAVIOUR_V0,
            max_joint_speed=BEHAVIOUR_V1.max_joint_speed if config.bound_joint_speed else None,
            continuous_quaternion=config.continuous_quaternion,
            target_from_observed_state=config.target_from_observed_state,
        )
