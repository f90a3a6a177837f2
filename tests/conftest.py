import os
import shutil
import tempfile

import matplotlib
import numpy as np
import pytest

matplotlib.use("Agg")

from slipnav.diagrams.open_loop import build_open_loop_diagram  # noqa: E402
from slipnav.diagrams.records import Belief, Truth  # noqa: E402
from slipnav.diagrams.robot import make_simulator  # noqa: E402
from slipnav.scenarios.artifact_arrays import collect_arrays  # noqa: E402
from slipnav.systems.navigation.mixing.parameters import MixingParameters  # noqa: E402
from slipnav.systems.rates import SampleRates  # noqa: E402
from slipnav.systems.robot.parameters import GRAVITY, RobotParameters  # noqa: E402
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP  # noqa: E402
from slipnav.systems.robot.sensors import SensorParameters  # noqa: E402


def run_open_loop(
    robot,
    wheel_speeds,
    duration,
    *,
    sensors=None,
    seed=0,
    initial_speed=0.0,
    plant_time_step=DEFAULT_TIME_STEP,
):
    """Drive the real open-loop diagram with a table of [v_R, v_L] rows at T_C; returns artifact arrays."""
    rates = SampleRates()
    wheel_speeds = np.asarray(wheel_speeds, float)
    poses = np.zeros((len(wheel_speeds), 3))
    truth = Truth(
        sensors=sensors or SensorParameters(),
        seed=seed,
        initial_speed=initial_speed,
        plant_time_step=plant_time_step,
    )
    built = build_open_loop_diagram(truth, Belief(robot=robot, rates=rates), wheel_speeds, poses)
    simulator = make_simulator(built.diagram, seed, robot.speed_loop_period)
    simulator.AdvanceTo(duration)
    return collect_arrays(built.loggers, simulator.get_context(), robot)


SHARED_PROCESS = {
    "tests/test_calibration.py": "calibration",
    "tests/test_calibration_session.py": "calibration",
}
"""Modules that run in one process together: the simulations they share (tests/shared.py)."""

SLOW_UNITS = {
    "tests/test_faults.py": 86,
    "calibration": 55,
    "tests/test_reproduce.py": 31,
    "tests/test_robustness.py": 27,
    "tests/test_navigation.py": 24,
    "tests/test_cli.py": 23,
    "tests/test_error_budget.py": 22,
    "tests/test_plain_loop.py": 22,
    "tests/test_control.py": 19,
    "tests/test_yaw_calibration.py": 17,
    "tests/test_tyre_peak.py": 15,
    "tests/test_standstill.py": 13,
    "tests/test_perturbation_monitor.py": 13,
    "tests/test_sensor_log.py": 11,
    "tests/test_plots.py": 10,
    "tests/test_artifacts.py": 10,
}
"""The units of work that take longest (seconds on the 2-core machine, measured; an order, not a
budget). They go out first, largest first, so that the last units to run are short and the two
processes finish together; the others follow by their number of tests (xdist's loadscope)."""

_SHARED_DIR = None


def pytest_configure(config):
    """The session's folder of shared simulations (tests/shared.py), made by the process that starts the
    session; pytest-xdist's workers inherit its name through the environment."""
    global _SHARED_DIR
    from tests.shared import SHARED_DIR_VARIABLE

    if not hasattr(config, "workerinput") and SHARED_DIR_VARIABLE not in os.environ:
        _SHARED_DIR = tempfile.mkdtemp(prefix="slipnav-tests-")
        os.environ[SHARED_DIR_VARIABLE] = _SHARED_DIR


def pytest_unconfigure(config):
    global _SHARED_DIR
    if _SHARED_DIR is not None:
        from tests.shared import SHARED_DIR_VARIABLE

        os.environ.pop(SHARED_DIR_VARIABLE, None)
        shutil.rmtree(_SHARED_DIR, ignore_errors=True)
        _SHARED_DIR = None


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hook: without xdist the suite runs in one process
def pytest_xdist_make_scheduler(config, log):
    """pytest-xdist (README's ``-n 2``): each module is a unit of work that one process runs, so that its
    module-scoped fixtures run once, and the modules of SHARED_PROCESS are one unit. (xdist's loadgroup
    would do this with marks, but pytest 9.2's node ids break it: pytest-xdist issue 1386.) The units of
    SLOW_UNITS go out first, the longest first; then the others, the ones with the most tests first
    (xdist's loadscope)."""
    from collections import OrderedDict

    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        _ordered = False

        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return SHARED_PROCESS.get(module, module)

        def _assign_work_unit(self, node) -> None:
            if not self._ordered:  # the queue is complete before the first unit goes out
                units = sorted(self.workqueue.items(), key=lambda unit: -SLOW_UNITS.get(unit[0], 0))
                self.workqueue = OrderedDict(units)  # stable: the others keep loadscope's order
                self._ordered = True
            super()._assign_work_unit(node)

    return ModuleScheduling(config, log)


@pytest.fixture
def open_loop():
    return run_open_loop


def navigation_tyres(p: RobotParameters) -> MixingParameters:
    """The navigation's tyre curve and drag of robot ``p``: a_peak = mu g f_w, B, C, the shoes' Coulomb
    mu_s (1 - f_w) g and viscous 2 c_v / m per unit mass, the slip's reference-speed floor."""
    return MixingParameters(
        tyre_peak_acceleration=p.traction_limit_acceleration,
        tyre_stiffness_factor=p.tyre_stiffness_factor,
        tyre_shape_factor=p.tyre_shape_factor,
        drag_acceleration=p.shoe_friction * (1.0 - p.wheel_load_fraction) * GRAVITY,
        drag_per_speed=2.0 * p.shoe_viscous_drag / p.mass,
        tyre_reference_speed=p.slip_speed_floor,
    )


@pytest.fixture(name="navigation_tyres")
def navigation_tyres_fixture():
    return navigation_tyres
