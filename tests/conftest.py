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


@pytest.hookimpl(optionalhook=True)  # pytest-xdist's hook: without xdist the suite runs in one process
def pytest_xdist_make_scheduler(config, log):
    """pytest-xdist (README's ``-n 2``): each module is a unit of work that one process runs, so that its
    module-scoped fixtures run once, and the modules of SHARED_PROCESS are one unit. (xdist's loadgroup
    would do this with marks, but pytest 9.2's node ids break it: pytest-xdist issue 1386.) The units go
    out the ones with the most tests first (xdist's loadscope)."""
    from xdist.scheduler import LoadScopeScheduling

    class ModuleScheduling(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            module = nodeid.split("::", 1)[0]
            return SHARED_PROCESS.get(module, module)

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
