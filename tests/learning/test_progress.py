"""Progress on stderr only where a person watches it: a terminal gets a bar, a log file gets no
carriage-return fragments."""

import io
import sys

import pytest

import drake_tooluse.learning.evaluate as evaluate_mod
from drake_tooluse.tasks.push.metrics import PUSH_EPISODE_METRICS


class Stderr(io.StringIO):
    def __init__(self, tty: bool):
        super().__init__()
        self.tty = tty

    def isatty(self):
        return self.tty


class Env:
    EPISODE_METRICS = PUSH_EPISODE_METRICS
    PHYSICAL_LIMITS = ()
    spec = None

    @property
    def unwrapped(self):
        return self

    def close(self):
        pass


INFO = {
    "object_to_goal": 0.01,
    "is_success": True,
    "sim_error": False,
    "object_travel": 0.2,
    "tool_touched_object_in_episode": True,
    "gripper_touched_object_in_episode": False,
}


@pytest.mark.parametrize("tty", [True, False])
def test_evaluate_shows_progress_only_on_a_terminal(monkeypatch, tty):
    monkeypatch.setattr(evaluate_mod, "make_policy_env", lambda *a: (None, Env()))
    monkeypatch.setattr(evaluate_mod, "run_episode", lambda env, policy, seed, **kw: (INFO, 40))
    err = Stderr(tty)
    monkeypatch.setattr(sys, "stderr", err)
    result = evaluate_mod.evaluate("policy", episodes=5, progress=True)
    assert result.episodes == 5 and result.success_rate == 1.0
    if tty:
        assert "\r" in err.getvalue() and "5/5" in err.getvalue()
    else:
        assert err.getvalue() == ""
    err = Stderr(True)
    monkeypatch.setattr(sys, "stderr", err)
    evaluate_mod.evaluate("policy", episodes=2)  # the library is quiet unless asked
    assert err.getvalue() == ""
