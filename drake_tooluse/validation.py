"""Checks for values entering the package: each error names the value and the allowed range."""

from __future__ import annotations

import math

import numpy as np


def _as_float(value, name: str) -> float:
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={value!r} is not a number") from None
    if not math.isfinite(x):
        raise ValueError(f"{name}={x} must be a finite number")
    return x


def check_in_range(
    value, lo: float, hi: float, name: str, unit: str = "", lower_inclusive: bool = True
) -> float:
    """Returns `value` as a float if lo <= value <= hi (lo < value when not inclusive)."""
    x = _as_float(value, name)
    ok_lo = x >= lo if lower_inclusive else x > lo
    if not (ok_lo and x <= hi):
        bracket = "[" if lower_inclusive else "("
        u = f" {unit}" if unit else ""
        raise ValueError(
            f"{name}={x:g}{u} is outside the allowed range {bracket}{lo:g}, {hi:g}]{u}"
        )
    return x


def check_positive(value, name: str, unit: str = "") -> float:
    return check_in_range(value, 0.0, math.inf, name, unit, lower_inclusive=False)


def check_finite_vector(values, size: int, name: str) -> np.ndarray:
    """Returns `values` as a float array of shape (size,), all finite."""
    try:
        a = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={values!r} is not a vector of {size} numbers") from None
    if a.size != size:
        raise ValueError(f"{name} has {a.size} values; it needs exactly {size}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name}={a.tolist()} must be finite (no NaN or inf)")
    return a


def check_one_of(value, allowed, name: str):
    if value not in allowed:
        raise ValueError(f"{name}={value!r} is not allowed; choose one of {list(allowed)}")
    return value


def check_unit_quaternion(wxyz, name: str = "quaternion") -> np.ndarray:
    """Returns the normalized quaternion (w, x, y, z); a zero or non-finite one is an error."""
    q = check_finite_vector(wxyz, 4, name)
    norm = float(np.linalg.norm(q))
    if norm < 1e-9:
        raise ValueError(
            f"{name}={q.tolist()} has zero norm; a rotation needs a non-zero "
            "quaternion (w, x, y, z)"
        )
    return q / norm
