"""Truth and belief: what the builders simulate and what the navigation and control know.

``Truth`` is the simulated robot as it really is (the plant, its sensors, their noise seed and faults, the
plant's integration step, the initial state); ``Belief`` is what the navigation and control read (the
nominal robot, the sensors' data sheet, the model's calibration, the tunings, the sample periods). The
builders (diagrams/closed_loop.py, diagrams/open_loop.py, diagrams/onboard.py) and the plain loop
(scenarios/plain_loop.py) take one of each.
"""

from __future__ import annotations

import dataclasses as dc

from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.navigation.parameters import (
    NavigationBelief,
    NavigationInitialState,
    NavigationParameters,
)
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP
from slipnav.systems.robot.sensors import SensorParameters, default_sensor_parameters


@dc.dataclass(frozen=True)
class Belief:
    """What the navigation and control read: never the plant.

    Args:
        robot: the nominal robot (RobotParameters) the navigation and control read.
        rates: the sample periods T_N, T_C (s) of the sensors, navigation and control.
        navigation: the navigation's tuning (None: no navigation, open loop only).
        sensors: the sensors' data sheet the navigation knows (None: the robot's, ``data_sheet``).
        calibration: the sensors' systematic errors the navigation removes (None: none).
        perturbation_monitor: the PerturbationMonitor's tuning (None: the defaults, ``monitor``).
        model: the RobotModel this belief was read from (scenarios/model.py; None: the nominal belief).
    """

    robot: RobotParameters
    rates: SampleRates = dc.field(default_factory=SampleRates)
    navigation: NavigationParameters | None = None
    sensors: SensorParameters | None = None
    calibration: SensorCalibration | None = None
    perturbation_monitor: PerturbationParameters | None = None
    model: object = None

    @property
    def data_sheet(self) -> SensorParameters:
        """The sensors' data sheet the navigation knows: ``sensors``, else the nominal robot's."""
        return self.sensors or default_sensor_parameters(self.robot.name)

    @property
    def monitor(self) -> PerturbationParameters:
        """The PerturbationMonitor's tuning: ``perturbation_monitor``, else PerturbationParameters()."""
        return self.perturbation_monitor or PerturbationParameters()

    def navigation_belief(self, initial: NavigationInitialState) -> NavigationBelief:
        """What the navigation is given of this belief, starting from ``initial``: the tuning, the nominal
        robot, the periods, the data sheet (``data_sheet``) and the calibration."""
        return NavigationBelief.of_robot(
            self.navigation, self.robot, self.rates, initial, self.data_sheet, self.calibration
        )


@dc.dataclass(frozen=True)
class Truth:
    """The simulated robot as it really is: never read by the navigation or control.

    Args:
        sensors: the real sensors (SensorParameters: noise, biases, resolution).
        seed: the sensors' noise seed (integer 0 .. 2**31-1).
        plant: the real robot (RobotParameters; None: the belief's nominal robot, ``robot``).
        initial_pose: the robot's initial pose (x m, y m, phi rad).
        initial_speed: the robot's initial forward speed (m/s).
        plant_time_step: the plant's integration step (s; 0: continuous, DifferentialDrivePlant).
        faults: FaultEvents on the sensors and the plant (systems/robot/faults.py).
    """

    sensors: SensorParameters
    seed: int
    plant: RobotParameters | None = None
    initial_pose: tuple = (0.0, 0.0, 0.0)
    initial_speed: float = 0.0
    plant_time_step: float = DEFAULT_TIME_STEP
    faults: tuple = ()

    @property
    def initial_state(self) -> NavigationInitialState:
        """The initial speed (m/s) and pose as the navigation starts from them."""
        return NavigationInitialState(speed=self.initial_speed, pose=tuple(self.initial_pose))

    def robot(self, belief: Belief) -> RobotParameters:
        """The simulated robot: ``plant``, else the ``belief``'s nominal robot."""
        return self.plant or belief.robot
