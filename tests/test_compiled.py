"""The optional numba compilation (systems/compiled.py): every compiled function gives the same numbers as
its Python source, bit for bit, and a closed-loop run is the same with and without numba."""

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from slipnav.systems import compiled
from slipnav.systems.health import (
    SensorHealthParameters,
    health_check,
    health_constants,
    health_initial_state,
)
from slipnav.systems.navigation.ekf import (
    EkfParameters,
    _covariance_update,
    _factored_covariance_update,
    ekf_gain,
    ekf_inertial_estimate,
    ekf_prior_covariance,
    joseph_factors,
    joseph_form,
    measured_inverse,
    mixed_covariance,
)
from slipnav.systems.navigation.parameters import NavigationParameters, health_geometry
from slipnav.systems.robot.contact import NO_DISTURBANCE
from slipnav.systems.robot.dynamics import _plant_steps
from slipnav.systems.robot.motors import MOTORS_ON
from slipnav.systems.robot.parameters import kurt3d, tinyphoon

T_N = 0.002
needs_numba = pytest.mark.skipif(not compiled.ENABLED, reason="numba not installed or SLIPNAV_NUMBA=0")


def assert_same(a, b):
    """Equal bit for bit (NaN where NaN), through tuples, lists and arrays."""
    if isinstance(a, (tuple, list)):
        assert isinstance(b, (tuple, list)) and len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            assert_same(x, y)
    else:
        np.testing.assert_array_equal(np.asarray(a), np.asarray(b), strict=False)


def both(function, *args):
    """(compiled result, Python result) of ``function`` on ``args``."""
    return function(*args), compiled.pure(function)(*args)


@needs_numba
@pytest.mark.parametrize("robot", [tinyphoon(), kurt3d()], ids=lambda p: p.name)
@pytest.mark.parametrize(
    "state, loop, command, disturbance, enable",
    [
        ((0.0,) * 10, (0.0,) * 4, (0.0, 0.0), NO_DISTURBANCE, MOTORS_ON),  # at rest
        ((0.1, -0.2, 0.3, 1.5, 0.02, 2.0, 4.0, 5.0, 110.0, 90.0), (0.01, -0.02, 3.0, 2.5), (2.0, 1.0))
        + (NO_DISTURBANCE, MOTORS_ON),  # turning, slipping
        ((0.0, 0.0, 1.0, 3.0, -0.1, -5.0, 0.0, 0.0, 150.0, 250.0), (0.5, 0.5, 6.0, -6.0), (4.0, -4.0))
        + ((0.0, 1.0, 0.0, 1.0, 0.001, 0.0, 0.5, -0.3), (1.0, 0.0)),  # lifted, held, pushed, one motor off
    ],
)
def test_plant_steps_compiled_equal_python(robot, state, loop, command, disturbance, enable):
    for steps, per_loop in ((4, 2), (20, 20), (1, 1)):
        args = (state, loop, command, 3, steps, per_loop, 5e-4, robot.constants, disturbance, enable)
        assert_same(*both(_plant_steps, *args))


def random_covariance(rng, scale=1.0):
    A = rng.normal(size=(5, 5)) * scale
    return A @ A.T + np.diag([1e-4, 1e-4, 1e-3, 1.0, 1.0])


@needs_numba
def test_ekf_functions_compiled_equal_python():
    rng = np.random.default_rng(7)
    params = EkfParameters()
    Q, R, _ = params.matrices()
    for scale in (1e-3, 1.0, 30.0):  # 30: the velocity variance limit and the cross-covariance bound act
        for _ in range(20):
            P = random_covariance(rng, scale)
            x = rng.normal(size=5) * np.array([2.0, 0.2, 10.0, 20.0, 20.0])
            L = ekf_gain(ekf_prior_covariance(P, x, Q, T_N), R)
            y = rng.normal(size=3)
            gain = (float(rng.uniform(0, 1)), float(rng.uniform(-0.5, 1)))
            assert_same(*both(ekf_prior_covariance, P, x, Q, T_N))
            assert_same(*both(ekf_inertial_estimate, x, L, y, T_N))
            A, noise = joseph_factors(L, R)
            assert_same(*both(joseph_form, P, A, noise))
            P_joseph = joseph_form(P, A, noise)
            inverse = measured_inverse(P_joseph)
            assert_same(*both(mixed_covariance, P_joseph, inverse, gain, (5e-6, 1e-4), 1.0))
            compiled_update = _factored_covariance_update(P, A, noise, gain, (5e-6, 1e-4), 1.0)
            assert_same(compiled_update, mixed_covariance(P_joseph, inverse, gain, (5e-6, 1e-4), 1.0))
            assert_same(_covariance_update(P, L, R, gain, (5e-6, 1e-4), 1.0), compiled_update)


@needs_numba
@pytest.mark.parametrize("enabled", [True, False])
def test_sensor_checks_compiled_equal_python(enabled):
    """A run of samples with noise, a jump, a stuck encoder, NaN and inf, a saturated gyro, a disagreeing
    accelerometer, motor currents read (the force reference) and missing, a lost gyro replaced by the
    yaw dynamics with and without the navigation's velocity: every state, output and code equal."""
    geometry = health_geometry(NavigationParameters(), 0.015, 0.068, T_N, robot=tinyphoon())
    constants = health_constants(SensorHealthParameters(enabled=enabled), geometry)
    rng = np.random.default_rng(3)
    state_c = state_p = health_initial_state(geometry, 0.5)
    theta = np.zeros(2)
    for k in range(400):
        theta += np.array([0.5, 0.45]) * T_N / 0.015
        raw = [*(rng.normal(size=4) * 0.3 + [0.0, 1.0, 0.0, 1.0]), 0.5 + 0.01 * rng.normal(), *theta]
        if 100 <= k < 110:
            raw[4] = 6.0  # saturated gyro (and a jump)
        if 150 <= k < 170:
            raw[5] = theta[0] - 0.5 * (k - 150) * T_N / 0.015  # the right encoder stuck
        if k in (200, 201):
            raw[1], raw[6] = math.nan, math.inf
        if 250 <= k < 300:
            raw[2] += 8.0  # accelerometer 2's t axis disagrees
        if 350 <= k < 390:
            raw[3] += 8.0  # and its n axis: blamed
        if 320 <= k < 340:
            raw[4] = math.nan  # the gyro lost: the yaw dynamics replace it, with and without the velocity
        raw = tuple(float(v) for v in raw)
        currents = (math.nan, math.nan) if k < 240 else (0.2 + 0.01 * rng.normal(), 0.2)
        velocity = (math.nan, math.nan) if k < 330 else (0.5, 0.01 * rng.normal())
        peak = math.nan if k < 325 else 4.0  # the identified tyre peak (m/s^2)
        learned = (0.0, 0.0) if k < 140 else (0.02, -0.008)  # the online calibration's b_g, D
        (state_c, out_c, codes_c), (state_p, out_p, codes_p) = (
            health_check(state_c, raw, currents, constants, velocity, peak, learned),
            compiled.pure(health_check)(state_p, raw, currents, constants, velocity, peak, learned),
        )
        assert_same((state_c, out_c, codes_c), (state_p, out_p, codes_p))
        assert [type(c) for c in codes_c] == [int] * 7
        if enabled and 360 <= k < 390:  # the pair blames accelerometer 2's n axis, not 1's
            assert codes_c[3] != 0 and codes_c[1] == 0


RUN = """
import json, sys
import numpy as np
from slipnav.systems import compiled
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.plain_loop import run_scenario_plain_loop
scenario = load_scenario("corner")
result = run_scenario_plain_loop(scenario, scenario.seed, 700)
np.savez(sys.argv[1], **result)
print(json.dumps({"enabled": compiled.ENABLED}))
"""


@needs_numba
def test_closed_loop_is_the_same_with_and_without_numba(tmp_path):
    """The corner's first 1.4 s (standstill, start, slip control acting) as the plain loop, in two
    processes, SLIPNAV_NUMBA=1 and 0: every signal equal bit for bit."""
    results = {}
    for flag in ("1", "0"):
        out = tmp_path / f"run{flag}.npz"
        env = {**os.environ, "SLIPNAV_NUMBA": flag}
        done = subprocess.run(
            [sys.executable, "-c", RUN, str(out)], env=env, capture_output=True, text=True, check=True
        )
        assert f'"enabled": {"true" if flag == "1" else "false"}' in done.stdout
        results[flag] = np.load(out)
    for key in results["1"].files:
        np.testing.assert_array_equal(results["1"][key], results["0"][key], err_msg=key)


def test_without_numba_the_functions_are_python():
    """SLIPNAV_NUMBA=0 (as without the extra): compiled() and jitable() return the functions themselves."""
    code = (
        "from slipnav.systems import compiled, health\n"
        "from slipnav.systems.navigation import ekf\n"
        "from slipnav.systems.robot import dynamics\n"
        "assert not compiled.ENABLED\n"
        "functions = (dynamics._plant_steps, dynamics.plant_substep, ekf.mixed_covariance)\n"
        "functions += (health.health_check, ekf.ekf_prior_covariance, ekf.ekf_inertial_estimate)\n"
        "for f in functions:\n"
        "    assert type(f).__name__ == 'function' and compiled.pure(f) is f, f\n"
    )
    env = {**os.environ, "SLIPNAV_NUMBA": "0"}
    subprocess.run([sys.executable, "-c", code], env=env, check=True)


def test_each_state_of_the_sources_compiles_into_its_own_cache(tmp_path):
    """numba's cache checks only the file that defines a compiled function; sources_cache_dir names the
    cache by the SHA-256 of every source below the package, so an edit to a jitable function in another
    module reaches the compiled code, and the same sources find the same cache."""
    from slipnav.systems.compiled import sources_cache_dir

    (tmp_path / "health").mkdir()
    (tmp_path / "check.py").write_text("def check(): return 1\n")
    (tmp_path / "health" / "analog.py").write_text("def analog(): return 2\n")
    first = sources_cache_dir(tmp_path)
    assert sources_cache_dir(tmp_path) == first
    (tmp_path / "health" / "analog.py").write_text("def analog(): return 3\n")
    changed = sources_cache_dir(tmp_path)
    assert changed != first and os.path.dirname(changed) == os.path.dirname(first)
    (tmp_path / "health" / "analog.py").write_text("def analog(): return 2\n")
    assert sources_cache_dir(tmp_path) == first
