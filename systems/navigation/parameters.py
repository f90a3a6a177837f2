"""What the navigation is given: its tuning (NavigationParameters, every part's parameters), its initial
state (NavigationInitialState), what the sensor checks know of the robot and its sensors
(health_geometry), and the record of all of it (NavigationBelief) that the navigation diagram
(diagrams/navigation.py) and the plain loop (systems/navigation/loop.py) take.
"""

import dataclasses as dc
import math
from types import SimpleNamespace

import numpy as np
from slipnav.systems.health import FORCE_REFERENCE_FIELDS, HealthGeometry, SensorHealthParameters
from slipnav.systems.health.yaw_witness import MIN_YAW_LAG_STEPS, yaw_lag_at_floor
from slipnav.systems.navigation.ekf import EkfParameters
from slipnav.systems.navigation.gyrodometry import GyrodometryParameters
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.odometry import wheel_radii
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.navigation.sideslip import SideSlipParameters
from slipnav.systems.navigation.standstill import StandstillParameters
from slipnav.systems.navigation.yaw_calibration import YawCalibrationParameters
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.robot.sensors import SensorParameters


@dc.dataclass
class NavigationParameters:
    """All tuning of the navigation diagram (each part documents its defaults)."""

    ekf: EkfParameters = dc.field(default_factory=EkfParameters)
    mixing: MixingParameters = dc.field(default_factory=MixingParameters)
    sideslip: SideSlipParameters = dc.field(default_factory=SideSlipParameters)
    gyrodometry: GyrodometryParameters = dc.field(default_factory=GyrodometryParameters)
    yaw_calibration: YawCalibrationParameters = dc.field(default_factory=YawCalibrationParameters)
    health: SensorHealthParameters = dc.field(default_factory=SensorHealthParameters)
    standstill: StandstillParameters = dc.field(default_factory=StandstillParameters)

    def validate(self) -> "NavigationParameters":
        """Re-run every part's range checks (YAML loading sets fields after construction)."""
        parts = (
            self.ekf,
            self.mixing,
            self.sideslip,
            self.gyrodometry,
            self.yaw_calibration,
            self.health,
            self.standstill,
        )
        for part in parts:
            part.__post_init__()
        return self


@dc.dataclass(frozen=True)
class NavigationInitialState:
    """Initial conditions shared by the diagram and the loop."""

    speed: float = 0.0
    pose: tuple = (0.0, 0.0, 0.0)

    def ekf_state(self) -> np.ndarray:
        return np.array([self.speed, 0.0, 0.0, 0.0, 0.0])

    def odometry_state(self) -> list:
        v = self.speed
        return [np.nan, np.nan, 0.0, v, 0.0, v, v]


DEFAULT_WHEEL_SPEED_BOUND = 10.0
"""Plausible wheel speed (m/s) when neither the health parameters nor the robot give one."""


SLIDE_ONSET_MIN_QUANTA = 3.0
"""The per-sample slide-onset test's threshold must exceed this many encoder counts of the 2 ms odometric
speed (one count, r dtheta / T_N, would set it at every flicker)."""


def check_slide_onset(mixing: MixingParameters, geometry: HealthGeometry) -> None:
    """Raise ValueError when mixing.slide_onset_jump is within SLIDE_ONSET_MIN_QUANTA encoder counts of one
    sample's odometric speed (the larger wheel's), naming the allowed range."""
    quantum = max(geometry.radius_R, geometry.radius_L) * geometry.encoder_step / geometry.T_N
    if mixing.slide_onset_jump < SLIDE_ONSET_MIN_QUANTA * quantum:
        raise ValueError(
            f"mixing.slide_onset_jump={mixing.slide_onset_jump!r} is out of range for these encoders "
            f"(one count is {quantum:.4g} m/s in a sample): allowed [{SLIDE_ONSET_MIN_QUANTA * quantum:.4g}, "
            "inf] m/s (inf: no per-sample test)"
        )


def health_geometry(
    params: NavigationParameters,
    wheel_radius,
    track_width: float,
    T_N: float,
    sensors: SensorParameters | None = None,
    no_load_speed: float | None = None,
    robot: RobotParameters | None = None,
) -> HealthGeometry:
    """What the sensor checks know: the nominal (or calibrated) geometry and the sensors' data sheet
    (default Tinyphoon's); the plausible wheel speed is the parameter's, else 1.5 x the nominal motors'
    no-load speed; the nominal ``robot``'s mass, motors and drags for the force reference (None: none)."""
    r_R, r_L = wheel_radii(wheel_radius)
    sensors = sensors or SensorParameters()
    bound = params.health.max_wheel_speed
    if bound is None:
        bound = 1.5 * no_load_speed if no_load_speed else DEFAULT_WHEEL_SPEED_BOUND
    force = {}
    if robot is not None:
        force = {name: float(getattr(robot, name)) for name in FORCE_REFERENCE_FIELDS}
        force["track_width"] = track_width  # the believed track, as the checks use it
        if yaw_lag_at_floor(SimpleNamespace(**force)) < MIN_YAW_LAG_STEPS * T_N:  # no lag to model
            force["yaw_inertia"] = 0.0
        del force["track_width"]
    return HealthGeometry(
        r_R,
        r_L,
        track_width,
        T_N,
        sensors.encoder_step,
        tuple(sensors.accelerometer_position),
        bound,
        gyro_noise_std=sensors.gyro_noise_std,
        accel_noise_std=sensors.accel_noise_std,
        accel_vibration_per_speed=sensors.accel_vibration_per_speed,
        accel_vibration_time_constant=sensors.accel_vibration_time_constant,
        accel_initial_bias_std=sensors.accel_initial_bias_std,
        accel_drift_density=sensors.accel_drift_density,
        inertial_hold_time=sensors.inertial_hold_time,
        gyro_resolution=sensors.gyro_resolution,
        accel_resolution=sensors.accel_resolution,
        encoder_hold_time=sensors.encoder_hold_time,
        accelerometer_sets=int(sensors.accelerometer_sets),
        tyre_peak_acceleration=robot.traction_limit_acceleration if robot is not None else math.inf,
        **force,
    )


@dc.dataclass(frozen=True)
class NavigationBelief:
    """What the navigation is given: its tuning, the believed geometry and sample periods, its initial
    state and what the sensor checks know of the sensors and the robot.

    Args:
        params: the tuning (NavigationParameters).
        wheel_radius: one radius for both wheels or the pair (r_R, r_L) of a calibrated model (m).
        track_width: the believed track width (m).
        rates: the sample periods T_N, T_C (s).
        initial: the initial speed and pose (default: at rest at the origin).
        sensors: the sensors' data sheet for the sensor checks (None: Tinyphoon's, SensorParameters()).
        no_load_speed: the nominal motors' no-load speed (m/s), 1.5 x which is the plausible wheel speed
            (None: health.max_wheel_speed, else DEFAULT_WHEEL_SPEED_BOUND).
        calibration: the model's SensorCalibration, removed from the checked inertial samples (None: none).
        robot: the nominal robot, whose mass, motors and drags give the sensor checks the force reference
            of the tangential accelerometers (None: none).
    """

    params: NavigationParameters
    wheel_radius: float | tuple
    track_width: float
    rates: SampleRates = dc.field(default_factory=SampleRates)
    initial: NavigationInitialState = dc.field(default_factory=NavigationInitialState)
    sensors: SensorParameters | None = None
    no_load_speed: float | None = None
    calibration: SensorCalibration | None = None
    robot: RobotParameters | None = None

    @classmethod
    def of_robot(
        cls,
        params: NavigationParameters,
        robot: RobotParameters,
        rates: SampleRates,
        initial: NavigationInitialState | None = None,
        sensors: SensorParameters | None = None,
        calibration: SensorCalibration | None = None,
    ) -> "NavigationBelief":
        """The belief of the nominal ``robot``: its wheel radii (r_R, r_L), track width, no-load speed and
        force figures, with the tuning ``params``, the ``rates``, the ``initial`` state (None: at rest at
        the origin), the data sheet ``sensors`` and the ``calibration``."""
        return cls(
            params=params,
            wheel_radius=(robot.radius_R, robot.radius_L),
            track_width=robot.track_width,
            rates=rates,
            initial=initial or NavigationInitialState(),
            sensors=sensors,
            no_load_speed=robot.no_load_speed,
            calibration=calibration,
            robot=robot,
        )

    def geometry(self) -> HealthGeometry:
        """What the sensor checks know (health_geometry), with the slide-onset test checked against the
        encoders' resolution (check_slide_onset: ValueError naming mixing.slide_onset_jump)."""
        geometry = health_geometry(
            self.params,
            self.wheel_radius,
            self.track_width,
            self.rates.T_N,
            self.sensors,
            self.no_load_speed,
            self.robot,
        )
        check_slide_onset(self.params.mixing, geometry)
        return geometry
