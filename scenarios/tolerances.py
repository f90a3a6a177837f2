"""Truth and belief: the simulated robot as it really is, apart from the nominal model that navigation and
control read.

A scenario's ``robot`` (+ ``robot_overrides``, ``sensor_overrides``) is the robot as its data sheet and a
tape measure describe it: navigation and control know only that. Its ``plant`` section says how the robot
in the simulation really differs from it:

- ``robot_overrides`` / ``sensor_overrides``: absolute values for the plant and sensors only (e.g. the floor's
  ``tyre_friction: 0.5``);
- ``deviations``: fixed relative deviations of the real robot (``wheel_radius_R: 0.01`` = the right wheel
  rolls on a radius 1 % larger than the nominal; misalignments in degrees);
- ``tolerances``: bounds of deviations drawn uniformly in [-bound, +bound] from the run's seed and added to
  the fixed ones (``slipnav run SCENARIO --tolerances`` puts in TOLERANCE_PRESET).

The draw uses its own random stream (numpy SeedSequence of (seed, 15)), so the sensor noise of a seed is
the same with and without tolerances, and the same seed draws the same robot.
"""

import dataclasses as dc
import math

import numpy as np
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.sensors import SensorParameters

TOLERANCE_STREAM = 15
"""Second entropy word of the tolerance draw's SeedSequence (seed, TOLERANCE_STREAM)."""


@dc.dataclass
class RobotDeviations:
    """Relative deviations of the real robot from its nominal model (0.01 = 1 % larger), misalignments in
    degrees. As tolerances: the bounds of uniform draws.

    Args:
        wheel_radius_R, wheel_radius_L: each wheel's rolling radius.
        track_width: the effective distance between the wheels' contact points.
        mass: the mass (a payload).
        yaw_inertia: the moment of inertia about the vertical.
        tyre_friction: the tyres' peak friction mu.
        tyre_stiffness_factor: the tyre curve's Pacejka B.
        shoe_drag: the felt shoes' Coulomb friction and viscous drag alike.
        gyro_scale: the gyro's sensitivity.
        accel1_scale, accel2_scale: each two-axis accelerometer's sensitivity.
        accel1_misalignment_deg, accel2_misalignment_deg: the angle by which each accelerometer's axes
            are turned against the body's (deg, about the vertical).
    """

    wheel_radius_R: float = 0.0
    wheel_radius_L: float = 0.0
    track_width: float = 0.0
    mass: float = 0.0
    yaw_inertia: float = 0.0
    tyre_friction: float = 0.0
    tyre_stiffness_factor: float = 0.0
    shoe_drag: float = 0.0
    gyro_scale: float = 0.0
    accel1_scale: float = 0.0
    accel2_scale: float = 0.0
    accel1_misalignment_deg: float = 0.0
    accel2_misalignment_deg: float = 0.0

    def is_zero(self) -> bool:
        return all(getattr(self, f.name) == 0.0 for f in dc.fields(self))


ANGLE_KEYS = ("accel1_misalignment_deg", "accel2_misalignment_deg")

TOLERANCE_PRESET = RobotDeviations(
    wheel_radius_R=0.01,
    wheel_radius_L=0.01,
    track_width=0.03,
    mass=0.0,
    yaw_inertia=0.0,
    tyre_friction=0.0,
    tyre_stiffness_factor=0.0,
    shoe_drag=0.0,
    gyro_scale=0.01,
    accel1_scale=0.02,
    accel2_scale=0.02,
    accel1_misalignment_deg=1.0,
    accel2_misalignment_deg=1.0,
)
"""Everyday tolerances of a small differential-drive robot (``--tolerances``), bounds of uniform draws:

- wheel radius +-1 % each: rubber tyres' manufacture, wear and load deformation; unequal wheel diameters
  and the effective wheelbase are the dominant systematic odometry errors (J. Borenstein, L. Feng,
  "Measurement and correction of systematic odometry errors in mobile robots", IEEE Trans. Robotics and
  Automation 12(6), 1996, UMBmark);
- track width +-3 %: the effective wheelbase lies somewhere in the tyres' contact patches, about 2 mm
  either way on Tinyphoon's 68 mm track (Borenstein & Feng's E_b);
- gyro sensitivity +-1 %: MEMS rate gyros of the ADXRS family ship with a sensitivity tolerance of several
  per cent; +-1 % is what a one-time calibration on a turntable leaves;
- accelerometer sensitivity +-2 % and misalignment +-1 deg: the ADXL family's data sheets give an
  alignment error of +-1 deg between package and sensing axes, and the sensitivity after a one-point
  calibration is good to a few per cent.
Friction, mass and shoe drag are not toleranced here: the floor and the payload change them by far more
than any tolerance, and the robustness study sets them as cases of their own.
"""


@dc.dataclass
class PlantTruth:
    """How the simulated robot really is (see the module docstring).

    Args:
        robot_overrides: RobotParameters fields of the plant only (absolute values).
        sensor_overrides: SensorParameters fields of the sensors only (absolute values).
        deviations: fixed relative deviations (RobotDeviations).
        tolerances: bounds of relative deviations drawn from the seed (RobotDeviations).
    """

    robot_overrides: dict[str, float] = dc.field(default_factory=dict)
    sensor_overrides: dict[str, float] = dc.field(default_factory=dict)
    deviations: RobotDeviations = dc.field(default_factory=RobotDeviations)
    tolerances: RobotDeviations = dc.field(default_factory=RobotDeviations)

    def validate(self) -> "PlantTruth":
        """Physical ranges, naming the key: every scale 1 + deviation +- bound stays in (0, 2), every
        misalignment within (-90, 90) deg, bounds >= 0."""
        for f in dc.fields(RobotDeviations):
            fixed, bound = getattr(self.deviations, f.name), getattr(self.tolerances, f.name)
            if not math.isfinite(bound) or bound < 0.0:
                raise ValueError(f"plant.tolerances.{f.name}={bound!r} is out of range: allowed >= 0")
            limit = 90.0 if f.name in ANGLE_KEYS else 1.0
            unit = " deg" if f.name in ANGLE_KEYS else " (a scale factor 1 + deviation in (0, 2))"
            if not (math.isfinite(fixed) and abs(fixed) < limit):
                allowed = f"(-{limit:g}, {limit:g}){unit}"
                raise ValueError(f"plant.deviations.{f.name}={fixed!r} is out of range: allowed {allowed}")
            if abs(fixed) + bound >= limit:
                raise ValueError(
                    f"plant.tolerances.{f.name}={bound!r} is out of range: |deviation| + tolerance must stay "
                    f"below {limit:g}{unit}"
                )
        return self


def draw_deviations(truth: PlantTruth, seed: int) -> dict[str, float]:
    """The real robot's deviations: the fixed ones plus uniform draws within the tolerances, from
    SeedSequence((seed, TOLERANCE_STREAM)); every key is drawn (in field order), so a seed gives the same
    robot whatever the bounds."""
    rng = np.random.default_rng([int(seed), TOLERANCE_STREAM])
    names = [f.name for f in dc.fields(RobotDeviations)]
    unit = rng.uniform(-1.0, 1.0, len(names))
    return {
        name: getattr(truth.deviations, name) + getattr(truth.tolerances, name) * u
        for name, u in zip(names, unit, strict=True)
    }


def apply_deviations(
    robot: RobotParameters, sensors: SensorParameters, deviations: dict[str, float]
) -> tuple[RobotParameters, SensorParameters]:
    """The plant's RobotParameters and SensorParameters with the relative deviations applied."""
    d = deviations
    shoe = 1.0 + d["shoe_drag"]
    plant = dc.replace(
        robot,
        rolling_radius_R=robot.radius_R * (1.0 + d["wheel_radius_R"]),
        rolling_radius_L=robot.radius_L * (1.0 + d["wheel_radius_L"]),
        track_width=robot.track_width * (1.0 + d["track_width"]),
        mass=robot.mass * (1.0 + d["mass"]),
        yaw_inertia=robot.yaw_inertia * (1.0 + d["yaw_inertia"]),
        tyre_friction=robot.tyre_friction * (1.0 + d["tyre_friction"]),
        tyre_stiffness_factor=robot.tyre_stiffness_factor * (1.0 + d["tyre_stiffness_factor"]),
        shoe_friction=robot.shoe_friction * shoe,
        shoe_viscous_drag=robot.shoe_viscous_drag * shoe,
    )
    true_sensors = dc.replace(
        sensors,
        gyro_scale_error=(1.0 + sensors.gyro_scale_error) * (1.0 + d["gyro_scale"]) - 1.0,
        accel1_scale_error=(1.0 + sensors.accel1_scale_error) * (1.0 + d["accel1_scale"]) - 1.0,
        accel2_scale_error=(1.0 + sensors.accel2_scale_error) * (1.0 + d["accel2_scale"]) - 1.0,
        accel1_misalignment=sensors.accel1_misalignment + math.radians(d["accel1_misalignment_deg"]),
        accel2_misalignment=sensors.accel2_misalignment + math.radians(d["accel2_misalignment_deg"]),
    )
    return plant, true_sensors


def plant_record(plant: RobotParameters, sensors: SensorParameters) -> dict[str, float]:
    """The true values a run artifact records (SI units, radians), keyed as the npz's ``plant_*`` scalars."""
    return {
        "wheel_radius_R": plant.radius_R,
        "wheel_radius_L": plant.radius_L,
        "track_width": plant.track_width,
        "mass": plant.mass,
        "yaw_inertia": plant.yaw_inertia,
        "tyre_friction": plant.tyre_friction,
        "tyre_stiffness_factor": plant.tyre_stiffness_factor,
        "tyre_shape_factor": plant.tyre_shape_factor,
        "shoe_friction": plant.shoe_friction,
        "shoe_viscous_drag": plant.shoe_viscous_drag,
        "gyro_scale_error": sensors.gyro_scale_error,
        "accel1_scale_error": sensors.accel1_scale_error,
        "accel2_scale_error": sensors.accel2_scale_error,
        "accel1_misalignment": sensors.accel1_misalignment,
        "accel2_misalignment": sensors.accel2_misalignment,
    }
