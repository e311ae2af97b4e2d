"""Meshcat servers: quiet unless a live view was asked for."""

import logging

from drake_tooluse.builders.visualization import start_meshcat


def test_a_recording_meshcat_logs_no_url_and_an_announced_one_does(caplog):
    caplog.set_level(logging.INFO, logger="drake")
    start_meshcat()
    assert not [r for r in caplog.records if "listening" in r.getMessage()]
    assert logging.getLogger("drake").level == logging.INFO  # restored
    start_meshcat(announce=True)
    assert [r for r in caplog.records if "listening" in r.getMessage()]
