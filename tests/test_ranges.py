"""The range checks of single parameter fields (systems/ranges.py): the interval is the message's."""

import math
import re

import numpy as np
import pytest
from slipnav.systems.ranges import interval, require_flag, require_in, require_integer, within


@pytest.mark.parametrize(
    "allowed, inside, outside",
    [
        ("(0, inf)", [1e-300, 1.0, 1e300], [0.0, -1.0, math.inf, math.nan]),
        ("(0, inf] m/s^2", [1.0, math.inf], [0.0, math.nan]),
        ("[0, 1)", [0.0, 0.5], [1.0, -1e-12, math.nan]),
        ("(-pi/2, pi/2) rad", [0.0, 1.5707], [math.pi / 2, -math.pi / 2]),
        ("0 (continuous) or (0, 0.01] s", [0.01, 1e-6], [0.0, 0.02]),
        ("(-1, 1) (a sensitivity > 0)", [-0.99, 0.99], [-1.0, 1.0]),
    ],
)
def test_the_brackets_include_and_the_parentheses_exclude(allowed, inside, outside):
    for value in inside:
        assert within(value, allowed) and require_in("x", value, allowed) == value
    for value in outside:
        assert not within(value, allowed)
        message = f"x={value!r} is out of range: allowed {allowed}"
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            require_in("x", value, allowed)


def test_values_are_numbers_not_bools_and_finite_when_asked():
    assert require_in("x", np.float32(0.5), "(0, 1)") == np.float32(0.5)
    for bad in (True, "0.5", None):
        with pytest.raises(ValueError, match="x=.* is out of range: allowed"):
            require_in("x", bad, "(0, 1]")
    with pytest.raises(ValueError, match=r"mass=inf is out of range: allowed \(0.0, inf\]"):
        require_in("mass", math.inf, "(0.0, inf]", finite=True)


def test_integers_and_flags():
    assert require_integer("n", 5, "integers in [2, 50]") == 5
    assert require_integer("n", np.int64(2), "integers in [2, 50]") == 2
    for bad in (5.0, True, 1, 51):
        with pytest.raises(ValueError, match=r"allowed integers in \[2, 50\]"):
            require_integer("n", bad, "integers in [2, 50]")
    assert require_flag("f", False) is False
    with pytest.raises(ValueError, match="f=1 is out of range: allowed true, false"):
        require_flag("f", 1)


def test_a_text_without_an_interval_is_refused():
    assert interval("integers in [1, 1000]") == (1.0, 1000.0, True, True)
    with pytest.raises(ValueError, match="states no interval"):
        interval("0, 1 or 2")
