"""Range checks of single parameter fields, each against the interval its message states.

``require_in(name, value, "(0, inf) s")`` reads the interval from the allowed text, in the notation of
the message: a bracket includes its bound and a parenthesis excludes it, so ``inf)`` excludes infinity
and ``inf]`` allows it; NaN is never within. A bound is a number, ``inf``, ``-inf``, ``pi/2`` or
``-pi/2``; the first interval in the text counts, and the rest (a unit, a remark, "integers in ") is only
text. A value is a number (int, float or numpy's) that is not a bool. Every check raises ValueError
"{name}={value!r} is out of range: allowed {allowed}" (out_of_range), as do the checks of one field
against another, which compare themselves and raise out_of_range.

The checks across parameters and against what the models can represent are systems/checks.py's.
"""

from __future__ import annotations

import functools
import math
import numbers
import re

_INTERVAL = re.compile(r"([\[(])\s*([^,\[\]()]+?)\s*,\s*([^,\[\]()]+?)\s*([\])])")
_CONSTANTS = {"inf": math.inf, "-inf": -math.inf, "pi/2": math.pi / 2, "-pi/2": -math.pi / 2}


def out_of_range(name: str, value, allowed: str) -> ValueError:
    """The error of every range check: "{name}={value!r} is out of range: allowed {allowed}"."""
    return ValueError(f"{name}={value!r} is out of range: allowed {allowed}")


@functools.lru_cache(maxsize=256)
def interval(allowed: str) -> tuple[float, float, bool, bool]:
    """(low, high, low included, high included) of the first interval written in ``allowed``."""
    found = _INTERVAL.search(allowed)
    if found is None:
        raise ValueError(f"{allowed!r} states no interval such as (0, inf) or [0, 1)")
    left, low, high, right = found.groups()
    return _bound(low), _bound(high), left == "[", right == "]"


def _bound(token: str) -> float:
    """A bound's value: a number or a constant of _CONSTANTS."""
    return _CONSTANTS[token] if token in _CONSTANTS else float(token)


def within(value: float, allowed: str) -> bool:
    """Whether the number ``value`` lies in the interval of ``allowed`` (NaN never does)."""
    low, high, low_included, high_included = interval(allowed)
    above = value >= low if low_included else value > low
    below = value <= high if high_included else value < high
    return above and below


def is_number(value) -> bool:
    """A real number (int, float or numpy's), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def is_integer(value) -> bool:
    """An integer (int or numpy's), not a bool."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool)


def require_in(name: str, value, allowed: str, *, finite: bool = False):
    """``value``, a number within the interval of ``allowed`` (module docstring); ``finite``: infinity is
    out whatever the bracket says. Raises out_of_range otherwise."""
    if not (is_number(value) and within(value, allowed) and (math.isfinite(value) or not finite)):
        raise out_of_range(name, value, allowed)
    return value


def require_integer(name: str, value, allowed: str):
    """``value``, an integer (int or numpy's, not a bool) within the interval of ``allowed`` (e.g.
    "integers in [2, 50]"). Raises out_of_range otherwise."""
    if not (is_integer(value) and within(value, allowed)):
        raise out_of_range(name, value, allowed)
    return value


def require_flag(name: str, value) -> bool:
    """``value``, True or False. Raises out_of_range ("allowed true, false") otherwise."""
    if not isinstance(value, bool):
        raise out_of_range(name, value, "true, false")
    return value


def require_each(fields, check, names: str, allowed: str, prefix: str = "") -> None:
    """``check`` (require_in, require_integer) of each of the space-separated ``names`` of ``fields``,
    in order, against ``allowed``; the message names the field ``prefix + name``."""
    for name in names.split():
        check(prefix + name, getattr(fields, name), allowed)
