"""Checks for values entering the package: each error names the value and the allowed range."""

from __future__ import annotations

import math

import numpy as np


class EnvironmentProblem(RuntimeError):
    """What this machine lacks or holds busy — a program, an optional package, the installed
    data, a run directory another process uses — named in the message with what to do; the
    command line reports it as a usage error (exit 2), where another RuntimeError is a bug."""


SEED_MAX = 2**32 - 1  # Drake's RandomGenerator and numpy's legacy seeding take 32 bits


def _as_float(value, name: str, allowed: str = "") -> float:
    where = f" {allowed}" if allowed else ""
    if isinstance(value, (bool, complex, np.complexfloating)):
        raise ValueError(f"{name}={value!r} is not a real number{where}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={value!r} is not a number{where}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name}={x} must be a finite number{where}")
    return x


def check_in_range(
    value, lo: float, hi: float, name: str, unit: str = "", lower_inclusive: bool = True
) -> float:
    """Returns `value` as a float if lo <= value <= hi (lo < value when not inclusive)."""
    bracket = "[" if lower_inclusive else "("
    u = f" {unit}" if unit else ""
    allowed = f"in the allowed range {bracket}{lo:g}, {hi:g}]{u}"
    x = _as_float(value, name, allowed)
    ok_lo = x >= lo if lower_inclusive else x > lo
    if not (ok_lo and x <= hi):
        raise ValueError(
            f"{name}={x:g}{u} is outside the allowed range {bracket}{lo:g}, {hi:g}]{u}"
        )
    return x


def check_positive(value, name: str, unit: str = "") -> float:
    return check_in_range(value, 0.0, math.inf, name, unit, lower_inclusive=False)


def all_finite(a: np.ndarray) -> bool:
    """Whether every value of the float array `a` is finite. A finite sum proves it in one
    cheap reduction (this runs several times per control step); only where the sum is not
    finite (a NaN or inf, or finite values that overflow it) does the exact test decide."""
    return math.isfinite(a.sum()) or bool(np.isfinite(a).all())


def check_finite_vector(values, size: int, name: str) -> np.ndarray:
    """Returns `values` as a float array of shape (size,), all finite."""
    try:
        a = np.asarray(values, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name}={values!r} is not a vector of {size} numbers") from None
    if a.size != size:
        raise ValueError(f"{name} has {a.size} values; it needs exactly {size}")
    if not all_finite(a):
        raise ValueError(f"{name}={a.tolist()} must be finite (no NaN or inf)")
    return a


def check_one_of(value, allowed, name: str):
    if value not in allowed:
        raise ValueError(f"{name}={value!r} is not allowed; choose one of {list(allowed)}")
    return value


def check_unit_quaternion(wxyz, name: str = "quaternion") -> np.ndarray:
    """Returns the normalized quaternion (w, x, y, z); a zero or non-finite one is an error."""
    q = check_finite_vector(wxyz, 4, name)
    norm = math.sqrt(q.dot(q))  # np.linalg.norm's arithmetic, without its dispatch cost
    if norm < 1e-9:
        raise ValueError(
            f"{name}={q.tolist()} has zero norm; a rotation needs a non-zero "
            "quaternion (w, x, y, z)"
        )
    return q / norm


def check_int(value, lo: int, hi: int, name: str) -> int:
    """Returns `value` as an int if it is an integer (not a bool, not a float) in [lo, hi]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}={value!r} must be an integer in [{lo}, {hi}]")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name}={int(value)} is outside the allowed range [{lo}, {hi}]")
    return int(value)


def check_seed(value, name: str = "seed", count: int = 1) -> int:
    """A seed: an integer in [0, 2**32 - 1]; with `count`, seeds value … value + count - 1
    must all be in range (an evaluation of `count` episodes)."""
    seed = check_int(value, 0, SEED_MAX, name)
    if seed + count - 1 > SEED_MAX:
        raise ValueError(
            f"{name}={seed} with {count} runs uses seeds up to {seed + count - 1}, beyond the "
            f"allowed range [0, {SEED_MAX}]"
        )
    return seed


def check_bool(value, name: str) -> bool:
    """A flag must be True or False (not 'no', not 0/1)."""
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    raise ValueError(f"{name}={value!r} must be True or False")


def check_mapping(value, name: str) -> dict:
    """A keyword-argument mapping: a dict with string keys (None is an empty one)."""
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise ValueError(
            f'{name} must be a mapping of names to values, e.g. {{"key": 1}}; '
            f"got {type(value).__name__} {value!r}"[:300]
        )
    return value
