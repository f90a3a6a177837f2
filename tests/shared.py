"""What several tests simulate alike, simulated once per test process (pytest-xdist runs the tests that
share it in one process: SHARED_PROCESS in conftest.py). The simulations are deterministic per seed, so
sharing changes no result; every read is a deep copy, so no test sees another's changes."""

import contextlib
import copy

import pytest
from slipnav.studies import calibration
from slipnav.studies.calibration import simulate_manoeuvres

_MANOEUVRES: dict = {}


def calibration_manoeuvres(scenario, seed: int):
    """``studies.calibration.simulate_manoeuvres(scenario, seed)`` (about 11 s of simulation), simulated once
    per robot and draw: the key is all that the simulation reads (the nominal robot, the drawn plant and
    sensors, the rates, the plant's step, the seed)."""
    key = (
        repr(scenario.robot_parameters()),
        repr(scenario.plant_parameters(seed, tolerances=True)),
        repr(scenario.rates()),
        scenario.plant_time_step,
        int(seed),
    )
    if key not in _MANOEUVRES:
        _MANOEUVRES[key] = simulate_manoeuvres(scenario, seed)
    return copy.deepcopy(_MANOEUVRES[key])


@contextlib.contextmanager
def shared_manoeuvres():
    """Within: studies.calibration.simulate_manoeuvres is calibration_manoeuvres (what simulated_calibration,
    ``slipnav calibrate --simulate`` and the robustness study's calibrated_model_path call)."""
    with pytest.MonkeyPatch.context() as m:
        m.setattr(calibration, "simulate_manoeuvres", calibration_manoeuvres)
        yield
