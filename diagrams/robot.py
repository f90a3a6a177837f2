"""The physical side of every diagram: plant and sensors with their seeded noise."""

from __future__ import annotations

import dataclasses as dc

import numpy as np
from pydrake.common import RandomGenerator
from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
from pydrake.systems.framework import DiagramBuilder
from slipnav.diagrams.records import Belief, Truth
from slipnav.systems.checks import (
    check_robot_physics,
    require_finite,
    require_instance,
    require_pose,
    require_seed,
)
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.faults import (
    PlantDisturbance,
    SensorFaultInjector,
    check_fault_events,
    has_plant_events,
    has_sensor_faults,
)
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP, DifferentialDrivePlant
from slipnav.systems.robot.sensors import ProprioceptiveSensors, SensorNoise, SensorParameters, initial_biases


@dc.dataclass
class RobotHandles:
    plant: DifferentialDrivePlant
    sensors: ProprioceptiveSensors
    noise: SensorNoise
    readings: object = None
    """What the navigation reads: the sensors, or the SensorFaultInjector after them."""


def add_robot_with_sensors(
    builder: DiagramBuilder,
    robot: RobotParameters,
    sensor_params: SensorParameters,
    T_N: float,
    seed: int,
    initial_pose=(0.0, 0.0, 0.0),
    initial_speed: float = 0.0,
    plant_time_step: float = DEFAULT_TIME_STEP,
    faults=(),
) -> RobotHandles:
    """Add the plant and the sensors with the seed's noise.

    The initial sensor biases are drawn from ``numpy.random.default_rng(seed)``; the white noise, drift
    and vibration draws are the seed's SensorNoise (systems/robot/sensors.py), which the sensors read row k at
    t_k: a run is a function of the seed alone.
    ``plant_time_step`` > 0 makes the plant discrete, updated with the sensors every T_N; 0: continuous.
    ``faults``: FaultEvents (systems/robot/faults.py); with sensor faults a SensorFaultInjector sits after the
    sensors and ``readings`` is it; with plant perturbations a PlantDisturbance feeds the plant's
    ``disturbance`` input.
    """
    faults = check_fault_events(faults)
    plant = builder.AddSystem(
        DifferentialDrivePlant(robot, initial_pose, initial_speed, plant_time_step, update_period=T_N)
    )
    plant.set_name("Robot plant")
    noise = SensorNoise(seed)
    bias0 = initial_biases(sensor_params, np.random.default_rng(seed))
    rates0 = (initial_speed / robot.radius_R, initial_speed / robot.radius_L)
    sensors = builder.AddSystem(ProprioceptiveSensors(sensor_params, T_N, bias0, rates0, noise))
    sensors.set_name("Sensors")
    builder.Connect(plant.GetOutputPort("state"), sensors.GetInputPort("plant_state"))
    builder.Connect(plant.GetOutputPort("body_acceleration"), sensors.GetInputPort("body_acceleration"))
    builder.Connect(plant.GetOutputPort("motor_currents"), sensors.GetInputPort("motor_currents"))
    if has_plant_events(faults):
        disturbance = builder.AddSystem(PlantDisturbance(faults, T_N))
        disturbance.set_name("Plant perturbations")
        builder.Connect(disturbance.get_output_port(0), plant.GetInputPort("disturbance"))
    readings = sensors
    if has_sensor_faults(faults):
        readings = builder.AddSystem(SensorFaultInjector(faults, T_N, sensor_params.encoder_step))
        readings.set_name("Sensor faults")
        for name in ("accelerometers", "gyro", "encoders"):
            builder.Connect(sensors.GetOutputPort(name), readings.GetInputPort(name))
    return RobotHandles(plant=plant, sensors=sensors, noise=noise, readings=readings)


PLANT_INTEGRATION_ACCURACY = 1e-2
"""Target accuracy of the error-controlled RK3 integrator. Measured on ``corner`` (3 s) against 1e-7:
position error 7e-5 m, velocity error 4e-4 m/s (far below the sensors' resolution), 3.5x faster than 1e-4."""


def make_simulator(diagram, seed: int, max_step: float) -> Simulator:
    """A Simulator with the plant's integrator settings, any random sources seeded from ``seed``.

    The same seed gives a bit-identical run: the sensor noise is the seed's SensorNoise (fixed when the
    diagram is built); ``SetRandomContext(context, RandomGenerator(seed))`` seeds any Drake random source
    a diagram may hold (the built-in ones hold none).
    """
    require_seed(seed)
    simulator = Simulator(diagram)
    integrator = ResetIntegratorFromFlags(simulator, "runge_kutta3", max_step)
    integrator.set_target_accuracy(PLANT_INTEGRATION_ACCURACY)
    diagram.SetRandomContext(simulator.get_mutable_context(), RandomGenerator(seed))
    simulator.Initialize()
    return simulator


def check_records(truth: Truth, belief: Belief) -> None:
    """The builders' common inputs (Python API), a Truth and a Belief: ValueError naming the field."""
    require_instance("truth", truth, Truth)
    require_instance("belief", belief, Belief)
    robot = belief.robot
    require_instance("belief.robot", robot, RobotParameters)
    check_robot_physics(robot, "belief.robot.")
    require_instance("truth.sensors", truth.sensors, SensorParameters)
    require_instance("belief.rates", belief.rates, SampleRates)
    require_seed(truth.seed, "truth.seed")
    require_pose("truth.initial_pose", truth.initial_pose)
    require_finite("truth.initial_speed", truth.initial_speed, 0.0, robot.wheel_speed_limit)
    require_finite("truth.plant_time_step", truth.plant_time_step, 0.0, 0.01)
