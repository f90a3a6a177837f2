"""What several tests simulate alike, simulated once per test session. The simulations are deterministic
per seed, so sharing changes no result; every read is a deep copy, so no test sees another's changes.

Within a process a result is kept in memory; across the processes of pytest-xdist (README's ``-n 2``) it
is kept as a pickle in the session's folder (SHARED_DIR_VARIABLE, made and removed by conftest.py), and
a lock per result makes one process simulate it while another that needs it waits for it."""

import contextlib
import copy
import dataclasses as dc
import fcntl
import hashlib
import os
import pickle
from pathlib import Path

import pytest
from slipnav.scenarios import runner
from slipnav.scenarios.config import load_scenario
from slipnav.studies import calibration
from slipnav.studies.calibration_manoeuvres import simulate_manoeuvres

_RUN_SCENARIO = runner.run_scenario  # the simulation, whatever a test patches runner's with (shared_runs)
SHARED_DIR_VARIABLE = "SLIPNAV_TEST_SHARED_DIR"
"""The environment variable naming the session's folder of shared results (conftest.pytest_configure)."""

_KEPT: dict = {}


def _once(key: str, compute):
    """compute(), once per session for ``key`` (deterministic: every run of compute gives the same)."""
    if key in _KEPT:
        return _KEPT[key]
    folder = os.environ.get(SHARED_DIR_VARIABLE)
    if not folder or not Path(folder).is_dir():
        _KEPT[key] = compute()
        return _KEPT[key]
    stem = Path(folder) / hashlib.sha1(key.encode()).hexdigest()
    with open(stem.with_suffix(".lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # released when closed
        data = stem.with_suffix(".pickle")
        if data.exists():
            value = pickle.loads(data.read_bytes())
        else:
            value = compute()
            partial = stem.with_suffix(".partial")
            partial.write_bytes(pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL))
            partial.replace(data)
    _KEPT[key] = value
    return value


def _run(scenario, options: dict) -> tuple:
    # None keeps the scenario's (run_scenario), and so do its own seed and tolerances=False: the same run
    kept = {"seed": scenario.seed, "tolerances": False}
    options = {k: v for k, v in options.items() if v is not None and not (k in kept and v == kept[k])}

    def simulate():
        logs = {}
        collect = runner.collect_arrays

        def keep_frenet_errors(loggers, context, robot, **kwargs):
            if "frenet_errors" in loggers:
                logs["frenet_errors"] = loggers["frenet_errors"].FindLog(context).data().copy()
            return collect(loggers, context, robot, **kwargs)

        with pytest.MonkeyPatch.context() as m:
            m.setattr(runner, "collect_arrays", keep_frenet_errors)
            result = _RUN_SCENARIO(scenario, **options)
        return result, logs.get("frenet_errors")

    key = "run " + repr((scenario, sorted(options.items())))
    return copy.deepcopy(_once(key, simulate))


def scenario_run(name: str, **options):
    """``run_scenario(load_scenario(name), **options)`` of a built-in scenario (a RunResult), simulated once
    per test session: the default corner, for one, is what eleven tests read."""
    return _run(load_scenario(name), options)[0]


def scenario_result(scenario, options=None, **overrides):
    """``run_scenario(scenario, options, **overrides)`` (a RunResult), simulated once per test session: the
    key is the scenario's repr (every field of it) and the options (a RunOptions' fields, then
    ``overrides``)."""
    fields = {} if options is None else {f.name: getattr(options, f.name) for f in dc.fields(options)}
    return _run(scenario, {**fields, **overrides})[0]


def scenario_frenet_errors(name: str, **options):
    """The follower's Frenet errors [s1, y1, theta] (the closed loop's ``frenet_errors`` logger, one column
    per T_C sample) of scenario_run(name, **options)."""
    return _run(load_scenario(name), options)[1]


@contextlib.contextmanager
def shared_runs(*modules):
    """Within: the ``run_scenario`` of each of ``modules`` (a study's, or studies.cli's for the command
    line's ``slipnav run``) is scenario_result."""
    with pytest.MonkeyPatch.context() as m:
        for module in modules:
            m.setattr(module, "run_scenario", scenario_result)
        yield


def calibration_manoeuvres(scenario, seed: int, tolerances: bool = True):
    """``studies.calibration.simulate_manoeuvres(scenario, seed, tolerances)`` (about 11 s of simulation),
    simulated once per robot and draw: the key is all that the simulation reads (the nominal robot, the
    drawn plant and sensors, the rates, the plant's step, the seed)."""
    key = "manoeuvres " + repr(
        (
            repr(scenario.robot_parameters()),
            repr(scenario.plant_parameters(seed, tolerances=tolerances)),
            repr(scenario.rates()),
            scenario.plant_time_step,
            int(seed),
        )
    )
    return copy.deepcopy(_once(key, lambda: simulate_manoeuvres(scenario, seed, tolerances)))


@contextlib.contextmanager
def shared_manoeuvres():
    """Within: studies.calibration.simulate_manoeuvres is calibration_manoeuvres (what simulated_calibration,
    ``slipnav calibrate --simulate`` and the robustness study's calibrated_model_path call)."""
    with pytest.MonkeyPatch.context() as m:
        m.setattr(calibration, "simulate_manoeuvres", calibration_manoeuvres)
        yield
