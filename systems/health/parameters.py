"""What the sensor checks know: their thresholds (SensorHealthParameters), the nominal robot and its
sensors' data sheets (HealthGeometry), both as one plain record (HealthConstants, health_record), and
the health codes they report."""

import collections
import dataclasses as dc
import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.layout import GAIN_WINDOW_MAX
from slipnav.systems.health.yaw_witness import yaw_test_threshold
from slipnav.systems.ranges import is_integer, out_of_range, require_each, require_in, require_integer

NO_CURRENTS = (math.nan, math.nan)
"""The motor current readings when none are read: the tangential accelerometers' reference is the
odometry's, and the perturbation monitor has no force test."""
PLAUSIBLE_CURRENT = 1.5
"""A current reading beyond this many times the driver's limit is implausible: no force reference or
force test from it (plausible_currents)."""
HEALTH_CLASSES = ("nonfinite", "saturated", "stuck", "jump", "inconsistent", "recovering")
"""Health code k (1..6) is HEALTH_CLASSES[k - 1]; 0 is healthy."""
NONFINITE, SATURATED, STUCK, JUMP, INCONSISTENT, RECOVERING = range(1, 7)
NUM_ANALOG, GYRO, FIRST_ENCODER, NUM_CHANNELS = 5, 4, 5, 7
"""A sample's channels [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L]: the analog ones first, the
gyro's index, the right encoder's, all of them."""


@jitable
def plausible_currents(currents, current_limit: float) -> bool:
    """Both readings [i_R, i_L] (A) within PLAUSIBLE_CURRENT times the driver's ``current_limit`` (False
    for NaN)."""
    plausible = PLAUSIBLE_CURRENT * current_limit
    return abs(currents[0]) <= plausible and abs(currents[1]) <= plausible


@jitable
def drive_torque(current: float, rate: float, p) -> float:
    """The torque a wheel's motor at ``current`` (A) puts on it less the bearing drag at its ``rate``
    (rad/s): k i - beta w (N m), what the ground and the wheel's inertia take (``p``: anything with
    RobotParameters' motor_constant and bearing_drag)."""
    return p.motor_constant * current - p.bearing_drag * rate


@dc.dataclass
class SensorHealthParameters:
    """Thresholds of the sensor checks; each test is stated in its module (systems/health/). Defaults: the
    data sheets of systems/robot/sensors.py; the rates of change 4-5x the largest change per sample in the
    fault-free built-in runs; the other thresholds above the fault-free built-ins' largest statistic.

    Args:
        enabled: check (False: only NaN/inf are replaced, by the last value).
        gyro_range: data-sheet full scale (rad/s): ADXRS300 300 deg/s.
        accel_range: data-sheet full scale (m/s^2): ADXL210E 10 g.
        saturation_fraction: a reading at this fraction of the full scale counts as saturated, in [0.5, 1].
        stuck_samples: repeats (analog) or still counts (encoder) before "stuck", in [2, 50] (0.1 s).
        stuck_tolerance: an analog change at most this large is a repeat (a real ADC's quantum).
        stuck_min_speed, stuck_speed_fraction: an encoder is stuck when it stands still while v_pred
            exceeds stuck_min_speed + stuck_speed_fraction |v_other| on average (m/s, 1); stuck_min_speed
            is also the counter-rotation test's speed floor and its anchor's tolerance (ground_speed.py).
        stuck_braking_deceleration: an encoder's still samples count only while the body brakes against
            that wheel's motion by at most this (m/s^2, in (0, inf]): a hard braking locks a wheel
            honestly. inf (default): at any braking. 3.0, above the built-ins' driving decelerations, goes
            with mixing.slide_onset_jump (README, Sensor faults); a counter that freezes in a hard braking
            then counts as still until the braking ends.
        gyro_max_step: largest plausible change of the gyro in one sample (rad/s).
        accel_max_step: the same for an accelerometer axis (m/s^2).
        max_wheel_speed: largest plausible circumferential wheel speed (m/s); 1.5 x the motors' no-load
            speed of the nominal robot if None.
        max_wheel_acceleration: largest plausible change of a wheel's circumferential speed (m/s^2).
        accel_consistency, accel_consistency_per_speed: the bound of the pair's averaged disagreement,
            accel_consistency + accel_consistency_per_speed |v_o| (m/s^2, 1/s; the commotion grows with the
            speed): the fault-free built-ins peak at 0.59 of it.
        consistency_samples: samples of that moving average, in [2, 50].
        fast_consistency_samples, fast_consistency_factor: a second, shorter average (in [1, 50]) flags
            the pair beyond fast_consistency_factor times the bound plus its rotational terms' noise
            (fast_pair_ratio; (0, inf], inf: off). 3 and 1.6: a 5 m/s^2 bias step flagged within a few
            samples; the fault-free built-ins peak at 0.90 of the bound with factor 1.
        bias_step_samples: the samples of an excluded gyro's bias-step block, in [2, 500]: 25 (50 ms).
        bias_step_yaw_rate: the block measures a bias only while the replacement stays within this (rad/s):
            0.15, driving straight (the calibration's change_yaw_rate), where a scale error reads nothing.
        yaw_slip_fraction: the share of the wheels' yaw rate the tyres' differential slip may leave
            unexplained, in the yaw test's residual variance, in [0, 1]: 0.2; also the summed tolerance of
            the re-admission block of a gyro the yaw test holds out (gyro.gyro_readmission).
        yaw_witness_lag: the witness's timing uncertainty against the gyro (s), in (0, inf): 0.02, one T_C.
        yaw_false_alarm_time: healthy driving (s) per false alarm of the yaw test, in (0, inf): 3600.
        encoder_readmission_samples: the samples of an excluded encoder's re-admission block, in [1, 50]:
            10 (T_C). One sample's bound lets a doubled encoder through below 0.3 m/s; the block's sum not.
        encoder_readmission_fraction: the block's summed tolerance beyond two counts, as a fraction of
            the predicted travel, in [0, 1]: 0.2, well above the differential slip of the built-ins' turns.
        gyro_readmission_samples: the samples of an excluded gyro's re-admission block, in [1, 50] (1: the
            first within the bound): 5 (10 ms); a skid's replacement (the odometric yaw rate reads 15-20 %
            high) can meet a biased gyro for a sample, not for five.
        gyro_readmission_fraction: the block's summed tolerance as a fraction of the replacement's summed
            magnitude, in [0, 1], for a gyro out for anything but the yaw test: 0.3; a doubled scale passes
            the sample bound as a turn slows, not the sum.
        clip_samples, clip_window: a reading that returns to its magnitude for the clip_samples-th time
            within the last clip_window readings (both in [2, 50]; clip_samples 0: off) sits at a rail.
            Quantised noise needs a larger clip_samples: with a quantum of the gyro's noise sigma, 399 of
            1000 healthy samples are flagged at 3, 43 at 10, none at 20.
        gain_threshold: the gain test flags the pair beyond this statistic, in (0, inf] (inf: off): 4,
            above the fault-free built-ins' peak of 2.76; it flags the open corner's x2 scales of a
            tangential axis, which the averages miss.
        gain_tolerance: the relative gain of an axis's two sensors the test allows, in [0, 1): 0.1, the
            sensitivity tolerances (+-2 % each) and the misalignment with margin; a x2 scale is 0.67.
        gain_samples: the informative samples the test sums, the last ones, in [2, 50].
        gain_block_samples: the exponential average of the disagreement and the regressors before the
            test, in [1, 50]: it takes out the white noise and most of the commotion.
        gain_cross_coupling: the other axis's acceleration, times this, counts as noise of the
            disagreement, in [0, inf): a hard braking's lateral axes disagree by about 5 % of a_t.
        gain_offset_allowance: the error of the learned pair offset the test allows for (m/s^2, in [0,
            inf)). 0 (default): trusted; the built-ins stand still for their first second, where the
            offset is learned. A robot that drives off at once: up to 0.2, two initial biases of 0.05.
        gain_release: a pair the gain test alone flagged is cleared once its statistic is below half the
            threshold and the gain's upper bound (pair_gain_upper_bound) below this, in (gain_tolerance, 1].
    """

    enabled: bool = True
    gyro_range: float = math.radians(300.0)
    accel_range: float = 10 * 9.81
    saturation_fraction: float = 0.99
    stuck_samples: int = 5
    stuck_tolerance: float = 0.0
    stuck_min_speed: float = 0.1
    stuck_speed_fraction: float = 0.3
    stuck_braking_deceleration: float = math.inf
    gyro_max_step: float = 0.5
    accel_max_step: float = 25.0
    max_wheel_speed: float | None = None
    max_wheel_acceleration: float = 150.0
    accel_consistency: float = 1.0
    accel_consistency_per_speed: float = 1.0
    consistency_samples: int = 15
    fast_consistency_samples: int = 3
    fast_consistency_factor: float = 1.6
    bias_step_samples: int = 25
    bias_step_yaw_rate: float = 0.15
    yaw_slip_fraction: float = 0.2
    yaw_witness_lag: float = 0.02
    yaw_false_alarm_time: float = 3600.0
    encoder_readmission_samples: int = 10
    encoder_readmission_fraction: float = 0.2
    gyro_readmission_samples: int = 5
    gyro_readmission_fraction: float = 0.3
    clip_samples: int = 3
    clip_window: int = 50
    gain_threshold: float = 4.0
    gain_tolerance: float = 0.1
    gain_samples: int = 40
    gain_block_samples: int = 5
    gain_cross_coupling: float = 0.06
    gain_offset_allowance: float = 0.0
    gain_release: float = 0.3

    def __post_init__(self):
        names = "gyro_range accel_range gyro_max_step accel_max_step max_wheel_acceleration accel_consistency"
        require_each(self, require_in, names, "(0, inf)")
        names = "bias_step_yaw_rate yaw_false_alarm_time yaw_witness_lag stuck_min_speed"
        require_each(self, require_in, names, "(0, inf)")
        if self.max_wheel_speed is not None:
            require_in("max_wheel_speed", self.max_wheel_speed, "(0, inf)")
        require_in("saturation_fraction", self.saturation_fraction, "[0.5, 1]")
        if not (is_integer(self.clip_samples) and self.clip_samples == 0):  # 0: off
            require_integer("clip_samples", self.clip_samples, "0 (off) or integers in [2, 50]")
        names = "stuck_samples consistency_samples clip_window"  # clip_window 50: the ring
        require_each(self, require_integer, names, "integers in [2, 50]")
        require_integer("bias_step_samples", self.bias_step_samples, "integers in [2, 500]")
        require_integer("gain_samples", self.gain_samples, f"integers in [2, {GAIN_WINDOW_MAX}]")
        require_in("gain_tolerance", self.gain_tolerance, "[0, 1)")
        if not require_in("gain_release", self.gain_release, "(0, 1]") > self.gain_tolerance:
            tolerance = f"gain_tolerance={self.gain_tolerance!r}"
            allowed = f"above {tolerance} (a gain within the tolerance must clear the pair)"
            raise out_of_range("gain_release", self.gain_release, allowed)
        names = "fast_consistency_samples encoder_readmission_samples gyro_readmission_samples"
        require_each(self, require_integer, names + " gain_block_samples", "integers in [1, 50]")
        names = "encoder_readmission_fraction gyro_readmission_fraction yaw_slip_fraction"
        require_each(self, require_in, names, "[0, 1]")
        names = "stuck_tolerance stuck_speed_fraction accel_consistency_per_speed gain_cross_coupling"
        require_each(self, require_in, names + " gain_offset_allowance", "[0, inf)")
        require_in("fast_consistency_factor", self.fast_consistency_factor, "(0, inf]")
        require_in("stuck_braking_deceleration", self.stuck_braking_deceleration, "(0, inf] m/s^2")
        require_in("gain_threshold", self.gain_threshold, "(0, inf]")


@dc.dataclass(frozen=True)
class HealthGeometry:
    """What the checks know of the robot and its sensors: nominal values only (data sheet, tape).

    Args:
        radius_R, radius_L: nominal (or calibrated) rolling radii (m). track_width: b (m).
        T_N: period (s). encoder_step: rad per count. accelerometer_position: (x, y) of accelerometer 1
        (m; accelerometer 2 at (-x, -y)). max_wheel_speed: plausible circumferential bound (m/s).
        gyro_noise_std: the gyro's white noise per sample (rad/s, data sheet): the fast pair test's
            allowance for the noise its rotational terms carry (FAST_ROTATION_SIGMAS) and the pair
            offset's (pair_offset_update).
        accel_noise_std, accel_vibration_per_speed, accel_vibration_time_constant: the accelerometers'
            white noise and commotion (data sheet and S(3)'s model, systems/robot/sensors.py): the gain test's
            noise (pair_gain_ratio) and the pair offset's (pair_offset_update).
        accel_initial_bias_std, accel_drift_density: the accelerometers' initial bias and its random
            walk (data sheet): the pair offset's prior and drift (pair_offset_update).
        inertial_hold_time: the longest time the inertial stream repeats a reading while healthy (s,
            data sheet or the import's measurement; SensorParameters): the stuck test allows it.
        gyro_resolution, accel_resolution: one converter count (rad/s, m/s^2; 0: continuous;
            SensorParameters): the clip test's allowance for quantisation (analog.clip_returns).
        encoder_hold_time: the longest time between fresh wheel-angle readings while healthy (s;
            SensorParameters): the jump test allows max_wheel_acceleration over it.
        accelerometer_sets: the two-axis accelerometers the robot carries (0, 1 or 2; SensorParameters):
            an absent set's channels are not judged and output their replacement (analog.py), and with
            fewer than two there is no pair (accelerometer_pair.pair_present).
        tyre_peak_acceleration: the nominal robot's tyre curve's peak mu g f_w (m/s^2; inf: none): the
            navigation's identified peak over it scales the replacement's tyre forces (yaw_follow_step's
            grip), so that a calibrated floor (mixing.tyre_peak_acceleration) counts from the start.
        mass ... shoe_normal_load: the nominal robot's figures (RobotParameters' names) for the force
            reference of the tangential accelerometers (accelerometer_pair.force_reference); mass 0: none.
        yaw_inertia ... slip_speed_floor: the nominal robot's yaw inertia, wheel load and tyre curve
            (RobotParameters' names) for the excluded gyro's replacement (yaw_follow_step); yaw_inertia 0:
            the odometric yaw rate itself.
    """

    radius_R: float
    radius_L: float
    track_width: float
    T_N: float
    encoder_step: float
    accelerometer_position: tuple
    max_wheel_speed: float
    gyro_noise_std: float = 0.014
    accel_noise_std: float = 0.062
    accel_vibration_per_speed: float = 0.3
    accel_vibration_time_constant: float = 0.005
    accel_initial_bias_std: float = 0.05
    accel_drift_density: float = 0.0065
    inertial_hold_time: float = 0.0
    gyro_resolution: float = 0.0
    accel_resolution: float = 0.0
    encoder_hold_time: float = 0.0
    accelerometer_sets: int = 2
    tyre_peak_acceleration: float = math.inf
    mass: float = 0.0
    wheel_inertia: float = 0.0
    motor_constant: float = 0.0
    motor_current_limit: float = 0.0
    bearing_drag: float = 0.0
    shoe_offset: float = 0.0
    shoe_friction: float = 0.0
    shoe_viscous_drag: float = 0.0
    shoe_slip_speed: float = 0.01
    shoe_normal_load: float = 0.0
    yaw_inertia: float = 0.0
    wheel_normal_load: float = 0.0
    tyre_friction: float = 0.0
    tyre_stiffness_factor: float = 0.0
    tyre_shape_factor: float = 0.0
    slip_speed_floor: float = 0.3


_RECORDED = (
    [f for f in dc.fields(SensorHealthParameters) if f.name != "max_wheel_speed"],  # the geometry's in force
    dc.fields(HealthGeometry),
)
"""The fields health_record copies: the thresholds, yaw_false_alarm_time as the yaw test's threshold,
then the geometry."""
_RECORD_FIELDS = [
    "yaw_threshold" if f.name == "yaw_false_alarm_time" else f.name for fields in _RECORDED for f in fields
]
DERIVED_FIELDS = (
    "analog_present saturation_level max_step clip_floor stuck_repeats "
    "encoder_jump_bound encoder_stuck_samples "
    "pair_offset_drift pair_offset_white pair_offset_phi pair_offset_rotation pair_offset_gate "
    "fast_rotation_allowance "
    "gain_block_gain gain_block_white gain_block_coloured gain_block_rotation "
    "yaw_residual_floor yaw_smoothing"
).split()
"""The figures the checks derive from the parameters and the geometry once, in check.health_constants,
instead of every sample; each is defined by the function that derives it (analog_constants,
encoder_constants, pair_constants, gain_constants, yaw_constants)."""
HealthConstants = collections.namedtuple("HealthConstants", _RECORD_FIELDS + DERIVED_FIELDS)
"""What health_check reads: SensorHealthParameters' thresholds, then HealthGeometry (its max_wheel_speed
is the bound in force), then the DERIVED_FIELDS."""
FORCE_REFERENCE_FIELDS = tuple(_RECORD_FIELDS[_RECORD_FIELDS.index("mass") :])
"""HealthGeometry's figures of the nominal robot for the force reference and the yaw dynamics
(RobotParameters' names)."""
NO_VELOCITY = (math.nan, math.nan)
"""health_check's ``velocity`` when the navigation's estimate is not read: the odometric v_t, no v_n."""
NO_YAW_CALIBRATION = (0.0, 0.0)
"""health_check's ``yaw_calibration`` without a calibration: gyro bias 0, rolling-radius difference 0."""


def health_record(p: SensorHealthParameters, g: HealthGeometry) -> HealthConstants:
    """The parameters and the geometry as one record in HealthConstants' order (bool, int or float as
    declared; accelerometer_position a pair of floats), the DERIVED_FIELDS None (check.health_constants
    fills them)."""
    values = []
    for source, fields in zip((p, g), _RECORDED, strict=True):
        for f in fields:
            value = getattr(source, f.name)
            if f.name == "yaw_false_alarm_time":  # the yaw test's CUSUM threshold (yaw_witness.py)
                values.append(yaw_test_threshold(value, g.T_N))
            elif f.type is tuple:
                values.append((float(value[0]), float(value[1])))
            else:
                values.append(f.type(value))  # bool, int or float
    return HealthConstants(*values, *([None] * len(DERIVED_FIELDS)))
