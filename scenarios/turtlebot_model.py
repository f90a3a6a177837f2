"""The TurtleBot 2 (Kobuki base, navX-MXP IMU) as the data sheets describe it: the model the phil-turtlebot
import writes (scenarios/import_turtlebot.py) when no --model is given."""

import math

from slipnav.scenarios.alignment import GRAVITY
from slipnav.scenarios.model import RobotModel

KOBUKI_TICKS_PER_REVOLUTION = 7735.0 / 3.0
"""Kobuki data sheet: 52 ticks per motor revolution times the 6545/132 gear, 2578.33 per wheel turn."""
KOBUKI_WHEEL_RADIUS = 0.035
KOBUKI_TRACK = 0.230
NAVX_GYRO_COUNT = math.radians(4000.0 / 65536)
"""rad/s: one count of the navX-MXP's gyro (data sheet: +-2000 deg/s in 16 bits)."""
NAVX_ACCEL_COUNT = 4.0 * GRAVITY / 65536
"""m/s^2: one count of its accelerometer (+-2 g in 16 bits)."""
NAVX_GYRO_DRIFT_DENSITY = math.radians(0.5) * math.sqrt(3.0) / 60.0**1.5
"""rad/s per sqrt(s): the random walk of the navX's gyro bias whose heading error grows to the maker's
0.5 deg per minute while moving (Kauai Labs' navX user guides, FAQ on yaw drift) at one standard
deviation: sigma_phi(t) = q t^(3/2) / sqrt(3), q = 3.2e-5."""
NAVX_ACCEL_INITIAL_BIAS_STD = 0.03 * GRAVITY
"""m/s^2: the navX's accelerometer offset at one standard deviation, the MPU-9250's zero-g initial
tolerance +-60 mg (its data sheet, x and y) taken as two; it covers the board's mounting tilt too
(1 deg leaks 0.17 m/s^2 of gravity)."""


def default_model() -> RobotModel:
    """The TurtleBot 2 as a model: Tinyphoon's sensor set and tuning with the Kobuki's data-sheet wheel
    radius, track and encoder resolution in thirds of a tick (7735 counts per revolution), and the navX's
    one accelerometer set, converter counts, gyro bias drift and accelerometer offset."""
    return RobotModel(
        robot="tinyphoon",
        description="TurtleBot 2 (Kobuki), data sheet: wheel radius 0.035 m, track 0.230 m, 2578.33 ticks "
        "per revolution (7735 counts of a third of a tick); navX IMU: one accelerometer set",
        robot_overrides={"wheel_radius": KOBUKI_WHEEL_RADIUS, "track_width": KOBUKI_TRACK},
        sensor_overrides={
            "encoder_counts_per_revolution": 7735,
            "accelerometer_sets": 1,
            "gyro_resolution": NAVX_GYRO_COUNT,
            "accel_resolution": NAVX_ACCEL_COUNT,
            "gyro_drift_density": NAVX_GYRO_DRIFT_DENSITY,
            "accel_initial_bias_std": NAVX_ACCEL_INITIAL_BIAS_STD,
        },
    ).validate()
