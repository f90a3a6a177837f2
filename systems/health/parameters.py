"""What the sensor checks know: their thresholds (SensorHealthParameters), the nominal robot and its
sensors' data sheets (HealthGeometry), both as one plain record (HealthConstants, health_record), and
the health codes they report."""

import collections
import dataclasses as dc
import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.layout import GAIN_WINDOW_MAX
from slipnav.systems.health.yaw_witness import yaw_test_threshold
from slipnav.systems.ranges import is_integer, out_of_range, require_in, require_integer

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


@dc.dataclass
class SensorHealthParameters:
    """Thresholds of the sensor checks (systems/health/: each test's module). Defaults: the data sheets of
    systems/robot/sensors.py and, for the rates of change, 4-5x the largest change per sample in the
    fault-free built-in runs (gyro 0.11 rad/s, accelerometers 6.4 m/s^2, wheel speed 0.14 m/s on Tinyphoon's
    square).

    Args:
        enabled: check (False: only NaN/inf are replaced, by the last value).
        gyro_range: data-sheet full scale (rad/s): ADXRS300 300 deg/s.
        accel_range: data-sheet full scale (m/s^2): ADXL210E 10 g.
        saturation_fraction: a reading at this fraction of the full scale counts as saturated.
        stuck_samples: repeats (analog) or still counts (encoder) before "stuck", in [2, 50] (0.1 s).
        stuck_tolerance: an analog change at most this large is a repeat (a real ADC's quantum).
        stuck_min_speed, stuck_speed_fraction: an encoder is stuck when it stands still while v_pred
            exceeds stuck_min_speed + stuck_speed_fraction |v_other| on average (m/s, 1).
        stuck_braking_deceleration: an encoder's still samples count only while the healthy
            accelerometers' mean a_t does not oppose that wheel's predicted motion by more than this
            (m/s^2; a braking sample restarts the count): a hard braking locks a
            wheel while the other still turns (the square at 5.8 m/s^2, one wheel commanded to a stop),
            and its honest standstill reads like a frozen counter. inf (default): the test counts at
            any braking. 3.0 (above the built-ins' driving decelerations outside such slides: drag
            0.5-1, slip control's steps) goes with mixing.slide_onset_jump (README, Sensor faults: it
            costs a counter that freezes in a hard braking, accepted as still until the braking ends).
        gyro_max_step: largest plausible change of the gyro in one sample (rad/s).
        accel_max_step: the same for an accelerometer axis (m/s^2).
        max_wheel_speed: largest plausible circumferential wheel speed (m/s); 1.5 x the motors' no-load
            speed of the nominal robot if None.
        max_wheel_acceleration: largest plausible change of a wheel's circumferential speed (m/s^2).
        accel_consistency, accel_consistency_per_speed: the two accelerometers may disagree, in the
            moving average over consistency_samples and beyond the rotational terms, by
            accel_consistency + accel_consistency_per_speed |v_o| (m/s^2; the commotion grows with the
            speed: the fault-free built-ins, matched and toleranced, peak at 0.59 of it, on the long
            path at 4 m/s; Tinyphoon's at 0.39).
        consistency_samples: samples of that average, in [2, 50].
        fast_consistency_samples, fast_consistency_factor: a second, shorter average of the same
            disagreement (fast_consistency_samples, in [1, 50]; as long as consistency_samples it is no
            faster) flags the pair as well when it exceeds fast_consistency_factor times the bound plus
            FAST_ROTATION_SIGMAS of its rotational terms' noise (fast_pair_ratio; inf: off), while the
            gyro is trusted on this and the previous sample. 3 and 1.6: the built-ins' fault-free fast
            averages (matched, tolerance draws, friction 0.5 and 0.9, mass +25 %, accelerometer scale
            and misalignment) peak at 0.60 of the bound with factor 1 on Tinyphoon and 0.90 on
            Kurt3D's long path at 4 m/s (its commotion); the allowance does not scale with the factor,
            so 1.6 keeps about 1.6 x of margin there and more on Tinyphoon. The short average flags a
            large bias step (5 m/s^2) within a few samples, before the long one fills.
        bias_step_samples: an excluded gyro's residual against its replacement is judged over blocks
            of this many samples for a new bias (gyro_bias_step_block), in [2, 500]: 25 (50 ms).
        bias_step_yaw_rate: the block measures a bias only while its replacement stays within this
            (rad/s): 0.15, driving straight (the calibration's change_yaw_rate), where a scale error or
            a sign flip reads nothing.
        yaw_slip_fraction: the share of the wheels' yaw rate that the tyres' differential slip may leave
            unexplained by the nominal yaw dynamics, in the yaw test's residual variance
            (systems/health/yaw_witness.py), in [0, 1]: 0.2.
        yaw_witness_lag: the witness's timing uncertainty against the gyro (s): the body's unmodelled
            lag behind the wheels and the sensor streams' relative latency, times the witness's rate of
            change, in the yaw test's residual variance, in (0, inf): 0.02, one T_C.
        yaw_false_alarm_time: healthy driving (s) per false alarm of the yaw test's CUSUM, in
            (0, inf): 3600, one an hour.
        encoder_readmission_samples: an excluded encoder is re-admitted only after a block of this
            many consecutive samples (in [1, 50]; 10 = T_C) that each agree with the prediction from the
            other wheel and the gyro, span READMISSION_TRAVEL_COUNTS of the encoder's counts, and whose
            summed difference from it stays within two counts plus
            encoder_readmission_fraction of the predicted travel. One sample's bound
            (max_wheel_acceleration T_N, 0.3 m/s) lets a doubled encoder through below 0.3 m/s; the
            quantisation telescopes over the block, a scale error does not (a doubled encoder re-admitted
            at 0.3 m/s reads v_t 0.15 m/s fast, half its wheel's excess). Like every channel it is
            kept out until a block agrees.
        encoder_readmission_fraction: the block's tolerance beyond two counts, as a fraction of the
            predicted travel, in [0, 1]: 0.2, well above the differential slip of the built-ins' turns.
        gyro_readmission_samples: an excluded gyro is re-admitted only after this many consecutive
            samples (in [1, 50]; 1: the first within the bound) within gyro_max_step of its replacement.
            A replacement departs from the true rate in a skid (the odometric yaw rate reads 15-20 % high
            in a skidding turn), so a gyro with a bias step can meet it within the bound for one sample,
            and re-admitted then it is trusted for the rest of its fault. 5 (10 ms): several samples
            against such a chance meeting, few enough that an outage ending in a skid is not held out
            much longer than the outage. Like every channel it is kept out until a block agrees.
        gyro_readmission_fraction: the gyro's block must also agree in sum: its summed difference from
            the replacement within 3 noise sigmas sqrt(n), two counts of each wheel's heading and this
            fraction (in [0, 1]) of the replacement's summed magnitude. A gyro's doubled scale passes the
            sample bound as a turn slows below gyro_max_step (its excess is the turn's own rate), while
            its sum over the block carries the whole excess. In the faults benchmark every other gyro
            fault (outages ending in the skid too) is re-admitted as with the sample bound alone.
        clip_samples, clip_window: a reading that returns to its magnitude for the clip_samples-th time
            (runs of repeats count once) within the last clip_window readings (both in [2, 50]), with no
            larger one between, sits at a rail: saturated, though below the data-sheet range (an
            amplifier's or a misconfigured range's clip; the benchmark clips at half the largest reading).
            Noise never repeats a value; with an ADC quantum (stuck_tolerance) the returns are judged
            within it, and quantised noise needs a larger clip_samples (a quantum of the gyro's noise
            sigma: 399 of 1000 healthy samples flagged at 3, 43 at 10, none at 20) or 0 (off).
        gain_threshold: the pair's gain test (pair_gain.pair_gain_ratio) flags the pair when
            its statistic exceeds this (in (0, inf]; inf: off). 4: above the statistic's peak over the
            built-ins' fault-free runs (matched and toleranced, open and closed loop), 2.76; it flags the
            open corner's x2 scales of a tangential axis, which the averages above miss.
        gain_tolerance: the relative gain between the two accelerometers of an axis that the test allows
            (in [0, 1)): 0.1, the preset's sensitivity tolerances (+-2 % each) and the misalignment's
            cross-coupling with margin; a x2 scale on one of them is 0.67, a x0.5 one -0.67.
        gain_samples: the test's sums are over this many informative samples, the last ones (in [2, 50]).
        gain_block_samples: the disagreement and the regressors are first averaged over this many
            samples (exponential, in [1, 50]), which takes the white noise and most of the commotion out.
        gain_cross_coupling: the other axis's acceleration, times this, counts as noise of the
            disagreement (in [0, inf)): in a hard braking (the square at 5.5 m/s^2) the lateral axes
            disagree by about 5 % of a_t on the nominal robot itself.
        gain_offset_allowance: an error of the learned offset between the two sensors (m/s^2, in
            [0, inf)) that the test allows for: it puts offset / |r| into the gain. 0 (default): the
            offset is trusted; the built-ins stand still for their first second, where the offset is
            learned and the test learns nothing (at rest the pair's mean is the sensors' biases, which a
            test there would read as a healthy sensor's gain). For a robot that drives off at
            once, the two sensors' initial biases (0.05 m/s^2 each, data sheet) differ by up to 0.2.
        gain_release: a pair the gain test alone flagged is cleared once its statistic is below half
            the threshold and |beta| plus GAIN_RELEASE_SIGMAS of its standard deviations below this (in
            (gain_tolerance, 1]): the evidence of a healthy gain. Cleared on the statistic alone, a
            doubled sensor comes back at a dip of its evidence (a beta two sigmas low) in the middle of
            its fault; on the bound alone, a well-measured moderate gain (a clipped axis's) is
            flagged and cleared on alternate samples. A pair the averages flagged is cleared on the
            averages' evidence (a bias's regression on a weak signal can hold the bound above this for
            seconds).
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


def require_each(fields, check, names: str, allowed: str, prefix: str = "") -> None:
    """``check`` (require_in, require_integer) of each of the space-separated ``names`` of ``fields``,
    in order, against ``allowed``; the message names the field ``prefix + name``."""
    for name in names.split():
        check(prefix + name, getattr(fields, name), allowed)


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
