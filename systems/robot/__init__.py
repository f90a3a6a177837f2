"""The simulated robot: a differential-drive rigid body with slipping tyres, DC motors and their speed loop,
its proprioceptive sensors, and the faults and perturbations injected into them.

- parameters.py: RobotParameters and the reference robots (tinyphoon, kurt3d);
- contact.py: the tyres' and felt shoes' forces on the body;
- motors.py: the DC motors and the sampled PI wheel-speed loop;
- dynamics.py: the plant ODE, its semi-implicit step and the discrete plant's advance;
- plant.py: the Drake block DifferentialDrivePlant;
- sensors.py: encoders, gyro, the accelerometer pair and the motor drivers' current sense, with their noise;
- faults.py: timed sensor faults and perturbations of the plant (FaultEvent and its two blocks).
"""

from slipnav.systems.robot.faults import FaultEvent, PlantDisturbance, SensorFaultInjector
from slipnav.systems.robot.parameters import ROBOTS, RobotParameters, kurt3d, robot_parameters, tinyphoon
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP, DifferentialDrivePlant
from slipnav.systems.robot.sensors import ProprioceptiveSensors, SensorParameters

__all__ = [
    "DEFAULT_TIME_STEP",
    "ROBOTS",
    "DifferentialDrivePlant",
    "FaultEvent",
    "PlantDisturbance",
    "ProprioceptiveSensors",
    "RobotParameters",
    "SensorFaultInjector",
    "SensorParameters",
    "kurt3d",
    "robot_parameters",
    "tinyphoon",
]
