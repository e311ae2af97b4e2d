"""Checks for values entering the package: each error names the value and the allowed range."""

from __future__ import annotations

import contextlib
import math
import reprlib

import numpy as np

from drake_tooluse.limits import SEED_MAX


class EnvironmentProblem(RuntimeError):
    """What this machine lacks or holds busy — a program, an optional package, the installed
    data, a run directory another process uses — named in the message with what to do; the
    command line reports it as a usage error (exit 2), where another RuntimeError is a bug."""


def _as_float(value, name: str, allowed: str = "") -> float:
    where = f" {allowed}" if allowed else ""
    if isinstance(value, (bool, complex, np.complexfloating)):
        raise ValueError(f"{name}={shown(value)} is not a real number{where}")
    try:
        x = float(value)
    except OverflowError:  # an integer past 1.8e308
        raise ValueError(f"{name}={shown(value)} must be a finite number{where}") from None
    except (TypeError, ValueError):
        raise ValueError(f"{name}={shown(value)} is not a number{where}") from None
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
        raise ValueError(f"{name}={shown(values)} is not a vector of {size} numbers") from None
    if a.size != size:
        raise ValueError(f"{name} has {a.size} values; it needs exactly {size}")
    if not all_finite(a):
        raise ValueError(f"{name}={shown(a.tolist())} must be finite (no NaN or inf)")
    return a


def check_one_of(value, allowed, name: str):
    if value not in allowed:
        raise ValueError(f"{name}={shown(value)} is not allowed; choose one of {list(allowed)}")
    return value


def check_unit_quaternion(wxyz, name: str = "quaternion") -> np.ndarray:
    """Returns the normalized quaternion (w, x, y, z); a zero or non-finite one is an error.
    Any other finite one is a rotation, however large its values (1e200 included)."""
    q = check_finite_vector(wxyz, 4, name)
    scale = float(np.abs(q).max())
    if scale >= 1e100:  # q.dot(q) would overflow: the same rotation, scaled down first
        q = q / scale
    norm = math.sqrt(q.dot(q))  # np.linalg.norm's arithmetic, without its dispatch cost
    if norm < 1e-9 and scale < 1e100:
        raise ValueError(
            f"{name}={q.tolist()} has zero norm; a rotation needs a non-zero "
            "quaternion (w, x, y, z)"
        )
    return q / norm


def check_int(value, lo: int, hi: int, name: str) -> int:
    """Returns `value` as an int if it is an integer (not a bool, not a float) in [lo, hi]."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name}={shown(value)} must be an integer in [{lo}, {hi}]")
    if not lo <= int(value) <= hi:
        raise ValueError(f"{name}={shown(int(value))} is outside the allowed range [{lo}, {hi}]")
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
    raise ValueError(f"{name}={shown(value)} must be True or False")


def check_mapping(value, name: str) -> dict:
    """A keyword-argument mapping: a dict with string keys (None is an empty one)."""
    if value is None:
        return {}
    if not isinstance(value, dict) or not all(isinstance(k, str) for k in value):
        raise ValueError(
            f'{name} must be a mapping of names to values, e.g. {{"key": 1}}; '
            f"got {type(value).__name__} {shown(value)}"
        )
    return value


class _Short(reprlib.Repr):
    def repr_int(self, x, level):
        if x.bit_length() > 128:  # (Python cannot print one of more than 4300 digits)
            return f"<an integer of {int(x.bit_length() * math.log10(2)) + 1} digits>"
        return repr(x)


_SHORT = _Short()
_SHORT.maxstring, _SHORT.maxother, _SHORT.maxlist, _SHORT.maxdict = 80, 80, 8, 8
_SHORT.maxtuple, _SHORT.maxlevel = 8, 3


def shown(value) -> str:
    """`value` as an error message quotes it: its repr, shortened (long strings, lists and
    mappings elided with "...", an integer of thousands of digits by its size), so that one
    bad value never makes a message of kilobytes."""
    return _SHORT.repr(value)


def clipped(text, limit: int = 300) -> str:
    """`text` on one line, at most `limit` characters (the rest elided with "...")."""
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 4] + " ..."


_DRAKE_FAILURE = "Failure at "


def drake_failure(error: BaseException) -> str | None:
    """The condition a failed Drake precondition names (pydrake raises one as SystemExit
    "Failure at <file>:<line> in <function>: condition '<c>' failed."), or None when `error`
    is not one."""
    text = str(error.code if isinstance(error, SystemExit) else error)
    if not isinstance(error, SystemExit) or not text.startswith(_DRAKE_FAILURE):
        return None
    _, _, where = text.partition(" in ")
    return " ".join(where.split()) or text


@contextlib.contextmanager
def refused_by_library(what: str):
    """Hands values the user gave (`what`: their names and values, e.g. "plant.stiction_tolerance
    =-1") to Drake or torch: a failure of theirs on them — a Drake precondition (which pydrake
    raises as SystemExit, past `except Exception`), a RuntimeError or ValueError of their C++, a
    MemoryError — becomes one ValueError naming `what`, with the library's reason. The checks
    at the boundary come first; this is the one place a value they miss is still named."""
    try:
        yield
    except EnvironmentProblem:
        raise
    except SystemExit as e:
        condition = drake_failure(e)
        if condition is None:
            raise
        raise ValueError(f"{what}: Drake refuses it ({condition})") from None
    except (RuntimeError, ValueError, TypeError, AssertionError, MemoryError) as e:
        raise ValueError(f"{what}: refused ({clipped(e) or type(e).__name__})") from None


def check_interval(r, name: str, unit: str, check) -> list[float]:
    """`[lo, hi]` with lo < hi, each end checked by `check(value, its name)`."""
    if not isinstance(r, (list, tuple)) or len(r) != 2:
        raise ValueError(f"{name}={r!r} must be [lo, hi] ({unit})")
    lo, hi = check(r[0], f"{name}[0]"), check(r[1], f"{name}[1]")
    if not lo < hi:
        raise ValueError(f"{name}={[lo, hi]} must have lo < hi")
    return [lo, hi]
