"""The tool's length range and its check: no Drake, so the command line checks a length before
it imports anything heavy."""

from __future__ import annotations

from drake_tooluse.validation import check_in_range

TOOL_LENGTH_RANGE = (0.0, 0.60)  # exclusive lower bound, inclusive upper bound (m)


def check_tool_length(length, name="tool length") -> float:
    """A tool length in (0, 0.60] m; returns it as a float."""
    lo, hi = TOOL_LENGTH_RANGE
    return check_in_range(length, lo, hi, name, unit="m", lower_inclusive=False)
