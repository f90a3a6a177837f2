"""What several tests simulate alike, simulated once per test process (pytest-xdist runs the tests that
share it in one process: SHARED_PROCESS in conftest.py). The simulations are deterministic per seed, so
sharing changes no result; every read is a deep copy, so no test sees another's changes."""

import contextlib
import copy

import pytest
from slipnav.scenarios import runner
from slipnav.scenarios.config import load_scenario
from slipnav.studies import calibration
from slipnav.studies.calibration_manoeuvres import simulate_manoeuvres

_MANOEUVRES: dict = {}
_RUNS: dict = {}


def _run(name: str, options: dict) -> tuple:
    scenario = load_scenario(name)
    # None keeps the scenario's (run_scenario), and so does its own seed: the same run
    options = {k: v for k, v in options.items() if v is not None and not (k == "seed" and v == scenario.seed)}
    key = (name, tuple(sorted(options.items())))
    if key not in _RUNS:
        logs = {}
        collect = runner.collect_arrays

        def keep_frenet_errors(loggers, context, robot, **kwargs):
            if "frenet_errors" in loggers:
                logs["frenet_errors"] = loggers["frenet_errors"].FindLog(context).data().copy()
            return collect(loggers, context, robot, **kwargs)

        with pytest.MonkeyPatch.context() as m:
            m.setattr(runner, "collect_arrays", keep_frenet_errors)
            result = runner.run_scenario(scenario, **options)
        _RUNS[key] = result, logs.get("frenet_errors")
    return copy.deepcopy(_RUNS[key])


def scenario_run(name: str, **options):
    """``run_scenario(load_scenario(name), **options)`` of a built-in scenario (a RunResult), simulated once
    per test process: the default corner, for one, is what eight tests read."""
    return _run(name, options)[0]


def scenario_frenet_errors(name: str, **options):
    """The follower's Frenet errors [s1, y1, theta] (the closed loop's ``frenet_errors`` logger, one column
    per T_C sample) of scenario_run(name, **options)."""
    return _run(name, options)[1]


def calibration_manoeuvres(scenario, seed: int, tolerances: bool = True):
    """``studies.calibration.simulate_manoeuvres(scenario, seed, tolerances)`` (about 11 s of simulation),
    simulated once per robot and draw: the key is all that the simulation reads (the nominal robot, the
    drawn plant and sensors, the rates, the plant's step, the seed)."""
    key = (
        repr(scenario.robot_parameters()),
        repr(scenario.plant_parameters(seed, tolerances=tolerances)),
        repr(scenario.rates()),
        scenario.plant_time_step,
        int(seed),
    )
    if key not in _MANOEUVRES:
        _MANOEUVRES[key] = simulate_manoeuvres(scenario, seed, tolerances)
    return copy.deepcopy(_MANOEUVRES[key])


@contextlib.contextmanager
def shared_manoeuvres():
    """Within: studies.calibration.simulate_manoeuvres is calibration_manoeuvres (what simulated_calibration,
    ``slipnav calibrate --simulate`` and the robustness study's calibrated_model_path call)."""
    with pytest.MonkeyPatch.context() as m:
        m.setattr(calibration, "simulate_manoeuvres", calibration_manoeuvres)
        yield
