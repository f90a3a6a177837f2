"""Plausibility and consistency checks of every sensor channel, before anything learns from it.

Each T_N sample [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L] is checked channel by channel. A
channel that fails is excluded (flagged with the class of the failure) and replaced by what the other
sensors say it should read (analytical redundancy) until it is plausible again.

Checks (health codes, 0 = healthy):

1. ``nonfinite``: NaN or inf.
2. ``saturated``: an analog reading at saturation_fraction of its data-sheet range (gyro 300 deg/s,
   accelerometers 10 g), or at a rail below it: the clip_samples-th return to one magnitude within
   clip_window readings with none larger between (clip_returns; a run of repeats counts once).
3. ``stuck``: an analog reading exactly repeated stuck_samples times (the sensors' white noise makes a
   repeat practically impossible; a real ADC's quantum is stuck_tolerance); an encoder whose count stands
   still for stuck_samples while the other wheel and the gyro say it turns faster than
   stuck_min_speed + stuck_speed_fraction |v_other| (v_pred = v_other +- b omega: a wheel held by hand,
   about which the robot pivots on rolling tyres, is not flagged), counted only while the body does not
   brake against that wheel's motion harder than stuck_braking_deceleration (a hard braking locks a wheel
   honestly; inf by default: counted at any braking).
4. ``jump``: the innovation test of S(2)'s prediction of omega and a (random walks: the prediction is
   the last accepted value) against what the robot can do in one sample (gyro_max_step,
   accel_max_step); an encoder increment implying a wheel speed beyond max_wheel_speed, or a change of
   the wheel speed beyond max_wheel_acceleration T_N plus two counts against both the last used and the
   last raw increment (so that a new level is re-acquired).
5. ``inconsistent``: the two accelerometers' same axes disagree, in a moving average over
   consistency_samples, by more than accel_consistency + accel_consistency_per_speed |v_o| beyond the
   rotational terms the gyro predicts (S(3)'s sensors at +-(x, y) differ by
   2 (-omega_dot y - omega^2 x, omega_dot x - omega^2 y), omega_dot from the gyro less b_g) and the
   pair's learned offset (the two biases' difference, a state that drifts as the data sheet says:
   pair_offset_update), or, in
   a second average over fast_consistency_samples (3) while the gyro is trusted, by
   fast_consistency_factor (1.6) times that bound plus the noise the gyro's difference puts into the
   rotational terms (fast_pair_ratio): a 5 m/s^2 step is flagged after 3-4 samples instead of 7-11; the one
   with the larger sum of its change since the pair began to disagree and its distance, in the same
   moving average, from the kinematic reference (d v_o/dt for t, v_o omega for n) is excluded until the
   pair's average falls below half the threshold and its fast average below half its own (the fast test
   is not judged without a trusted gyro: a hold may then clear, and the fast test flag the sensor
   again). A third test, the pair's gain (pair_gain_ratio), regresses the disagreement on each sensor's
   own signal over the last gain_samples informative samples: a scale fault on one sensor (x2: a gain of
   0.67 on the pair's mean) flags the pair beyond gain_tolerance once the evidence passes gain_threshold,
   although the disagreement stays inside the averages' bounds, and clears a pair it alone flagged when
   that evidence is gone (below half the threshold) and there is evidence of a gain within gain_release
   (pair_gain_upper_bound), or when no sample is informative for GAIN_HORIZON
   gain_samples samples (a standstill, where a scale does no harm). With the motor
   drivers' current readings the t axes'
   reference is the force balance instead, what the motors put on the ground over the nominal mass
   (sum (k i - beta w - J w')/r plus the shoe drag, / m), which does not slip as d v_o/dt does, and
   the distance from it alone decides (a hard braking moves the healthy sensor as much as a bias).
   The gyro is ``inconsistent`` when the yaw test (systems/yaw_witness.py) finds its yaw rate in a turn
   unconfirmed by the wheels' witness (the nominal yaw dynamics driven by the wheels) and not supported
   by the accelerometer pair's |omega|: held out (hold) until a re-admission block that turned
   YAW_RELEASE_HEADING agrees in sum.
6. ``recovering``: excluded, waiting to agree again with its redundant estimate.

Replacements: an excluded gyro reads the yaw rate the nominal yaw dynamics give the body from the wheels'
speeds (yaw_follow_step: the odometric yaw rate lagged by the tyres' slip and held back by the shoes'
scrub; the plain odometric yaw rate without the nominal robot's figures), both encoders healthy, else its
last value; the wheels' speeds there are corrected by the online calibration's rolling-radius difference D
(omega_o + D v_o / b, systems/yaw_calibration.py) and the output carries its gyro bias b_g, which the
navigation removes, as an excluded encoder's v_R - v_L = b (gyro - b_g) - D v_o does; a frozen gyro's
replacement starts from the wheels' yaw rate run through the repeats it was trusted for, and the heading
those repeats missed is paid back over the next stuck_samples samples; a saturated gyro reads the
accelerometer pair's yaw rate (pair_omega_squared, averaged over consistency_samples), at least its full
scale, with the gyro's sign, unless the odometry says below the full scale and the pair does not say more
than both it and PAIR_SPIN_MARGIN times the odometric yaw rate (the gyro reads beyond the robot: the
wheels' yaw rate above); one clipped at a rail below the range reads the wheels' yaw rate, without both
encoders the pair's, at least the rail; an accelerometer axis reads the other accelerometer's plus the
rotational difference, omega' from the gyro's difference (noisy per sample, but what the EKF integrates is
exact; without it the pair's mean is omega' x off, v_n x omega at the end of a turn), plus the pair's
offset learned while both agreed (pair_offset_update, a Kalman filter that weighs each sample by its noise:
the two sensors' bias difference, 0.08 m/s^2 on the corner, would otherwise shift the mean by half); an
encoder advances by v_pred T_N / r (the other
wheel and the gyro), else by its last increment. A stuck encoder's travel missed before the detection is
added then; the first increment after an exclusion (it spans the gap) is never used.

An excluded analog channel is re-admitted when within its jump bound of its replacement (the gyro for a block
of gyro_readmission_samples in a row whose summed difference is within gyro_readmission_fraction of the
replacement's, so that a scale error does not come back as a turn slows), an encoder when
its increments agree with v_pred sample by sample and, summed over a block of
encoder_readmission_samples, within two counts plus encoder_readmission_fraction of the predicted travel
(a doubled encoder passes one sample's bound at low speed; with no prediction, one increment agreeing with
the previous one suffices). No exclusion ends on a timer: a channel whose readings never agree again
(a sign-flipped or dead encoder, an accelerometer with a bias beyond its jump bound) stays out to the
end, its replacement serving. A gyro that comes back at a new level is no such channel: while it is
out, its residual against the replacement is judged over blocks of bias_step_samples, and a block that
shows a steady offset while the wheels say the robot drives straight hands that offset to the
calibration as a bias step (gyro_bias_step_block); the gyro, less the new b_g, then agrees and is
re-admitted. The gyro's reference and the replacements read the gyro less b_g.
"""

import collections
import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.compiled import compiled, jitable
from slipnav.systems.plant import shoe_drag
from slipnav.systems.yaw_witness import CUSUM as YAW_CUSUM
from slipnav.systems.yaw_witness import (
    GRIP_STIFFNESS_RATIO,
    YAW_TEST_SIZE,
    count_yaw_rate,
    gyro_yaw_test,
    tyre_grip,
    yaw_follow_step,
    yaw_test_initial_state,
    yaw_test_threshold,
    yaw_witness_step,
)

NO_CURRENTS = (math.nan, math.nan)
"""The motor current readings when none are read: the tangential accelerometers' reference is the
odometry's, and the perturbation monitor has no force test."""
PLAUSIBLE_CURRENT = 1.5
"""A current reading beyond this many times the driver's limit is implausible: no force reference or
force test from it."""
HEALTH_CLASSES = ("nonfinite", "saturated", "stuck", "jump", "inconsistent", "recovering")
"""Health code k (1..6) is HEALTH_CLASSES[k - 1]; 0 is healthy."""
NONFINITE, SATURATED, STUCK, JUMP, INCONSISTENT, RECOVERING = range(1, 7)
PAIR_SPIN_MARGIN = 1.5
"""A gyro railed at its full scale while the odometry says below it reads the accelerometer pair's yaw
rate only when the pair says more than the full scale and this many times the odometric yaw rate (a
spin the wheels do not see: a lifted wheel's), else the wheels'. (Not the wheels' yaw dynamics: they
carry the replacement's own last value.) On Tinyphoon's +-(0.02, 0.015) m the pair's
yaw rate, averaged over 15 samples, reads up to 5.4 rad/s while the body turns at 4.1 (open and closed
corner, 10 seeds), above the 5.2 rad/s full scale: a doubled gyro read max(full scale, pair) there (open
corner seed 9: 4.3 deg of heading, 85 mm)."""
NUM_CHANNELS = 7
READMISSION_TRAVEL_COUNTS = 10.0
"""An encoder excluded for a disagreement (a jump, a stuck count, an increment or a block off the
prediction) has its re-admission block judged only once the encoder itself has counted this many counts
in it (five times the block's two-count allowance): at rest a sign-flipped or doubled encoder agrees with
any prediction, so the block goes on until the wheel has turned enough to tell. One excluded for a
non-finite reading comes back at rest."""
YAW_RELEASE_HEADING = 0.05
"""A gyro the yaw test holds out is re-admitted only by a block whose replacement turned this much (rad,
3 deg): driving straight says nothing of a scale error."""
BIAS_STEP_SIGMAS = 4.0
"""An excluded gyro's residual may spread this many of its noise sigmas (plus the wheels' quantisation)
over a block that measures a new bias (gyro_bias_step_block): a gyro that reads noise, or a turn the
wheels do not see, is no bias."""
FAST_ROTATION_SIGMAS = 5.0
"""The fast pair test's bound allows this many standard deviations of the noise that the gyro's
sample-to-sample difference (omega') puts into the fast average's rotational terms, 2 omega' y (t) and
2 omega' x (n): Kurt3D's accelerometers sit at +-(0.1, 0.05) m, Tinyphoon's at +-(0.02, 0.015) m."""


@dc.dataclass
class SensorHealthParameters:
    """Thresholds of the sensor checks (module docstring). Defaults: the data sheets of
    systems/sensors.py and, for the rates of change, 4-5x the largest change per sample in the fault-free
    built-in runs (gyro 0.11 rad/s, accelerometers 6.4 m/s^2, wheel speed 0.14 m/s on Tinyphoon's
    square).

    Args:
        enabled: check (False: only NaN/inf are replaced, by the last value, as before).
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
            speed: 4 seeds of each built-in, matched and toleranced, peak at 0.59 of it, on the long
            path at 4 m/s; Tinyphoon's at 0.39).
        consistency_samples: samples of that average, in [2, 50].
        fast_consistency_samples, fast_consistency_factor: a second, shorter average of the same
            disagreement (fast_consistency_samples, in [1, 50]; as long as consistency_samples it is no
            faster) flags the pair as well when it exceeds fast_consistency_factor times the bound plus
            FAST_ROTATION_SIGMAS of its rotational terms' noise (fast_pair_ratio; inf: off), while the
            gyro is trusted on this and the previous sample. 3 and 1.6: the built-ins' fault-free fast
            averages (matched, tolerance draws, friction 0.5 and 0.9, mass +25 %, accelerometer scale
            and misalignment; 3 seeds) peak at 0.60 of the bound with factor 1 on Tinyphoon and 0.90 on
            Kurt3D's long path at 4 m/s (its commotion); the allowance does not scale with the factor,
            so 1.6 keeps about 1.6 x of margin there and more on Tinyphoon. A 5 m/s^2 bias step is
            flagged after 3-4 samples instead of 7-11 (open corner, seed 1: a lateral axis's bias,
            20 -> 10 ms, 12.2 -> 8.7 x the fault-free error).
        bias_step_samples: an excluded gyro's residual against its replacement is judged over blocks
            of this many samples for a new bias (gyro_bias_step_block), in [2, 500]: 25 (50 ms).
        bias_step_yaw_rate: the block measures a bias only while its replacement stays within this
            (rad/s): 0.15, driving straight (the calibration's change_yaw_rate), where a scale error or
            a sign flip reads nothing.
        yaw_slip_fraction: the share of the wheels' yaw rate that the tyres' differential slip may leave
            unexplained by the nominal yaw dynamics, in the yaw test's residual variance
            (systems/yaw_witness.py), in [0, 1]: 0.2.
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
            quantisation telescopes over the block, a scale error does not (the square's final braking:
            a x2 encoder re-admitted at 0.33 m/s read v_t 0.15 m/s fast). Like every channel it is
            kept out until a block agrees.
        encoder_readmission_fraction: the block's tolerance beyond two counts, as a fraction of the
            predicted travel, in [0, 1]: 0.2, well above the differential slip of the built-ins' turns.
        gyro_readmission_samples: an excluded gyro is re-admitted only after this many consecutive
            samples (in [1, 50]; 1: the first within the bound) within gyro_max_step of its replacement.
            Measured when the replacement was the odometric yaw rate, which reads 15-20 % high in a
            skidding turn: a gyro with a 1 rad/s bias step met it within the bound for a sample (corner,
            bias from 2.19 s: re-admitted after 60 ms and trusted for the rest of the step, 26 deg of
            heading, 0.47 m). 5 (10 ms): 3 already kept that gyro out (2.2 deg, as an outage); an outage
            ending in the skid cost 6.8 -> 7.2 mm with 5, 8.2 with 10. Like every channel it is
            kept out until a block agrees.
        gyro_readmission_fraction: the gyro's block must also agree in sum: its summed difference from
            the replacement within 3 noise sigmas sqrt(n), two counts of each wheel's heading and this
            fraction (in [0, 1]) of the replacement's summed magnitude. A gyro's doubled scale passes the
            sample bound as a turn slows below gyro_max_step (the open corner, seed 1: re-admitted at
            0.36 rad/s, 0.5 deg of heading, 7.3 mm against 1.5 fault-free; with the block 2.1 mm). In the
            faults benchmark every other gyro fault (outages ending in the skid too) is re-admitted as
            with the sample bound alone.
        clip_samples, clip_window: a reading that returns to its magnitude for the clip_samples-th time
            (runs of repeats count once) within the last clip_window readings (both in [2, 50]), with no
            larger one between, sits at a rail: saturated, though below the data-sheet range (an
            amplifier's or a misconfigured range's clip; the benchmark clips at half the largest reading).
            Noise never repeats a value; with an ADC quantum (stuck_tolerance) the returns are judged
            within it, and quantised noise needs a larger clip_samples (a quantum of the gyro's noise
            sigma: 399 of 1000 healthy samples flagged at 3, 43 at 10, none at 20) or 0 (off).
        gain_threshold: the pair's gain test (module docstring, 5.; pair_gain_ratio) flags the pair when
            its statistic exceeds this (in (0, inf]; inf: off). 4: over 104 fault-free runs of the
            built-ins (corner and square 10 seeds, long path and circle 3, matched and toleranced, open
            and closed loop) the statistic peaks at 2.76; the open corner's x2 scales of a tangential
            axis, which the averages above miss, are flagged 38-118 ms after their onset.
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
            learned and the test learns nothing (at rest the pair's mean is the sensors' biases: the
            tolerance preset's corner seed 6 flagged accel2_t there). For a robot that drives off at
            once, the two sensors' initial biases (0.05 m/s^2 each, data sheet) differ by up to 0.2.
        gain_release: a pair the gain test alone flagged is cleared once its statistic is below half
            the threshold and |beta| plus GAIN_RELEASE_SIGMAS of its standard deviations below this (in
            (gain_tolerance, 1]): the evidence of a healthy gain. Cleared on the statistic alone, a
            doubled sensor came back at a dip of its evidence (beta 0.38 for 0.67, two sigmas low on
            40 samples) in the middle of its fault; on the bound alone, a well-measured gain of 0.25
            was flagged and cleared on alternate samples (the square's clipped accel2_t: accel1_t
            blamed). A pair the averages flagged is cleared on their evidence as before (a bias's
            regression on a weak signal can hold the bound above this for seconds).
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
        for name in (
            "gyro_range accel_range gyro_max_step accel_max_step max_wheel_acceleration accel_consistency "
            "bias_step_yaw_rate yaw_false_alarm_time yaw_witness_lag stuck_min_speed"
        ).split():
            _positive(name, getattr(self, name))
        if self.max_wheel_speed is not None:
            _positive("max_wheel_speed", self.max_wheel_speed)
        if not (
            isinstance(self.saturation_fraction, (int, float)) and 0.5 <= self.saturation_fraction <= 1.0
        ):
            raise ValueError(
                f"saturation_fraction={self.saturation_fraction!r} is out of range: allowed [0.5, 1]"
            )
        value = self.clip_samples
        if isinstance(value, bool) or not isinstance(value, int) or not (value == 0 or 2 <= value <= 50):
            raise ValueError(
                f"clip_samples={value!r} is out of range: allowed 0 (off) or integers in [2, 50]"
            )
        for name in ("stuck_samples", "consistency_samples", "clip_window"):  # clip_window 50: the ring
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not (2 <= value <= 50):
                raise ValueError(f"{name}={value!r} is out of range: allowed integers in [2, 50]")
        value = self.bias_step_samples
        if isinstance(value, bool) or not isinstance(value, int) or not (2 <= value <= 500):
            raise ValueError(f"bias_step_samples={value!r} is out of range: allowed integers in [2, 500]")
        value = self.gain_samples
        if isinstance(value, bool) or not isinstance(value, int) or not (2 <= value <= GAIN_WINDOW_MAX):
            raise ValueError(f"gain_samples={value!r} is out of range: allowed integers in [2, 50]")
        value = self.gain_tolerance
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0.0 <= value < 1.0):
            raise ValueError(f"gain_tolerance={value!r} is out of range: allowed [0, 1)")
        value = self.gain_release
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0.0 < value <= 1.0):
            raise ValueError(f"gain_release={value!r} is out of range: allowed (0, 1]")
        if not value > self.gain_tolerance:
            raise ValueError(
                f"gain_release={value!r} is out of range: allowed above "
                f"gain_tolerance={self.gain_tolerance!r} (a gain within the tolerance must clear the pair)"
            )
        for name in (
            "fast_consistency_samples",
            "encoder_readmission_samples",
            "gyro_readmission_samples",
            "gain_block_samples",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not (1 <= value <= 50):
                raise ValueError(f"{name}={value!r} is out of range: allowed integers in [1, 50]")
        for name in ("encoder_readmission_fraction", "gyro_readmission_fraction", "yaw_slip_fraction"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0.0 <= value <= 1.0):
                raise ValueError(f"{name}={value!r} is out of range: allowed [0, 1]")
        for name in (
            "stuck_tolerance",
            "stuck_speed_fraction",
            "accel_consistency_per_speed",
            "gain_cross_coupling",
            "gain_offset_allowance",
        ):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name}={value!r} is out of range: allowed [0, inf)")
        for name, unit in (
            ("fast_consistency_factor", ""),
            ("stuck_braking_deceleration", " m/s^2"),
            ("gain_threshold", ""),
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not value > 0.0:
                raise ValueError(f"{name}={value!r} is out of range: allowed (0, inf]{unit}")


def _positive(name: str, value) -> None:
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, float))
        or not (math.isfinite(value) and value > 0)
    ):
        raise ValueError(f"{name}={value!r} is out of range: allowed (0, inf)")


@dc.dataclass(frozen=True)
class HealthGeometry:
    """What the checks know of the robot and its sensors: nominal values only (data sheet, tape).

    Args:
        radius_R, radius_L: nominal (or calibrated) rolling radii (m). track_width: b (m).
        T_N: period (s). encoder_step: rad per count. accelerometer_position: (x, y) of accelerometer 1
        (m; accelerometer 2 at (-x, -y)). max_wheel_speed: plausible circumferential bound (m/s).
        gyro_noise_std: the gyro's white noise per sample (rad/s, data sheet): the fast pair test's
            allowance for the noise its rotational terms carry (FAST_ROTATION_SIGMAS).
        accel_noise_std, accel_vibration_per_speed, accel_vibration_time_constant: the accelerometers'
            white noise and commotion (data sheet and S(3)'s model, systems/sensors.py): the gain test's
            noise (pair_gain_ratio) and the pair offset's (pair_offset_update).
        accel_initial_bias_std, accel_drift_density: the accelerometers' initial bias and its random
            walk (data sheet): the pair offset's prior and drift (pair_offset_update).
        tyre_peak_acceleration: the nominal robot's tyre curve's peak mu g f_w (m/s^2; inf: none): the
            navigation's identified peak over it scales the replacement's tyre forces (yaw_follow_step's
            grip), so that a calibrated floor (mixing.tyre_peak_acceleration) counts from the start.
        mass ... shoe_normal_load: the nominal robot's figures (RobotParameters' names) for the force
            reference of the tangential accelerometers (module docstring, 5.); mass 0: none.
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


# State layout (flat, for a Drake discrete state): per analog channel (5 each) the reference (last
# accepted or replaced value), the last raw reading, its repeat count, the inconsistency hold and the
# samples excluded; per encoder (2 each) the last finite raw angle, the output angle less that reading,
# the last used increment, still samples, predicted travel while still and its absolute sum, code, lost,
# the last raw increment; then the accelerometer pair (below).
_REF, _LAST, _REPEAT, _HOLD, _EXCL = (slice(5 * i, 5 * i + 5) for i in range(5))
_E = 25  # encoder slots; _E_OUT holds the output angle less the last finite raw reading
_E_LAST, _E_OUT, _E_INC, _E_STILL, _E_PRED, _E_ABS, _E_CODE, _E_LOST, _E_RAW = (
    slice(_E + 2 * i, _E + 2 * i + 2) for i in range(9)
)
# Accelerometer pair: averages of the disagreement (t, n); 1 when this sample's encoder output restored a
# stuck encoder's missed travel (_RESTORED); the previous odometric v,
# each sensor's averaged deviation from the kinematic reference (t1, n1, t2, n2), each sensor's level
# before the pair became suspect (t1, n1, t2, n2), the pair's averaged omega^2, the pair's learned offset
# a_1 - a_2 beyond the rotational terms (t, n). Last, per encoder (2 each), the re-admission block:
# its agreeing samples, their summed difference from the prediction and the predicted travel; then the
# excluded gyro's agreeing samples (its re-admission block); the pair's fast averages (t, n); the gyro's
# block: its summed difference from the replacement and the replacement's summed magnitude (rad/s).
_W = _E + 18
_RESTORED = _W + 2
_OFFSET = _W + 13
_R_COUNT, _R_DIFF, _R_TRAVEL = (slice(_W + 15 + 2 * i, _W + 17 + 2 * i) for i in range(3))
_G_COUNT = _W + 21
_FAST = _W + 22
_G_DIFF, _G_TRAVEL = _W + 24, _W + 25
# Per analog channel the last CLIP_WINDOW_MAX readings (a ring, NaN: none), then the ring's position.
CLIP_WINDOW_MAX = 50
_RING = _W + 26
_RING_POS = _RING + 5 * CLIP_WINDOW_MAX
# A frozen gyro's repeats: the wheels' yaw rate run through them, the heading they missed against it, and
# the payback still due (rate per sample, samples left).
_G_SHADOW, _G_OWED, _G_PAY_RATE, _G_PAY_LEFT = (_RING_POS + 1 + i for i in range(4))
# The pair's gain test, per axis (t, n; GAIN_SLOTS each): the block averages of the disagreement, of the
# pair's mean, of half the rotational difference and of the other axis's mean; the GAIN_SERIES sums
# (pair_gain_ratio); the samples counted, the entries in the window. Then, per axis, its ring position;
# then per axis its ring: the last GAIN_WINDOW_MAX products of each sum and the samples' numbers.
GAIN_SERIES = 6
GAIN_SLOTS = 4 + GAIN_SERIES + 2
GAIN_WINDOW_MAX = 50
_GAIN = _RING_POS + 5
_GAIN_POS = _GAIN + 2 * GAIN_SLOTS
_GAIN_RING = _GAIN_POS + 2
# The variance of the pair's learned offset (t, n; pair_offset_update).
_OFFSET_VAR = _GAIN_RING + 2 * (GAIN_SERIES + 1) * GAIN_WINDOW_MAX
# An excluded gyro's bias-step block (gyro_bias_step_block): its samples, the sums of its residual and
# of the residual's square, the largest |replacement| in it; then the bias step handed over this sample.
_B_COUNT, _B_SUM, _B_SQUARES, _B_TURN, _B_STEP = (_OFFSET_VAR + 2 + i for i in range(5))
# Per encoder, its own travel (|increments| summed) in the re-admission block.
_R_MOVED = slice(_B_STEP + 1, _B_STEP + 3)
# The gyro's witness from the wheels (rad/s, NaN: restart) and the yaw test's CUSUM (systems/yaw_witness.py).
_Y_WITNESS = _B_STEP + 3
_Y_TEST = slice(_Y_WITNESS + 1, _Y_WITNESS + 1 + YAW_TEST_SIZE)
_Y_SMOOTH = _Y_WITNESS + 1 + YAW_TEST_SIZE  # the witness's PT1 over yaw_witness_lag (NaN: restart)
# Per encoder, 1 while its exclusion is for a disagreement (a jump, a stuck count, a failed block): its
# re-admission block needs READMISSION_TRAVEL_COUNTS of its own counts.
_R_SUSPECT = slice(_Y_SMOOTH + 1, _Y_SMOOTH + 3)
STATE_SIZE = _Y_SMOOTH + 3


def health_initial_state(g: HealthGeometry, initial_speed: float = 0.0) -> np.ndarray:
    """Nothing read yet (the first finite reading is accepted); wheels rolling at ``initial_speed``."""
    s = np.zeros(STATE_SIZE)
    nan_parts = (_REF, _LAST, _E_LAST, _E_OUT, _E_RAW, slice(_W + 8, _W + 12), slice(_RING, _RING_POS))
    witness = (slice(_Y_WITNESS, _Y_WITNESS + 1), slice(_Y_SMOOTH, _Y_SMOOTH + 1))
    for part in (*nan_parts, slice(_G_SHADOW, _G_SHADOW + 1), *witness):
        s[part] = np.nan
    s[_E_INC] = [initial_speed * g.T_N / g.radius_R, initial_speed * g.T_N / g.radius_L]
    s[_W + 3] = initial_speed
    s[_OFFSET_VAR : _OFFSET_VAR + 2] = 2.0 * g.accel_initial_bias_std**2  # two sensors' biases
    s[_Y_TEST] = yaw_test_initial_state()
    return s


HealthConstants = collections.namedtuple(
    "HealthConstants",
    "enabled gyro_range accel_range saturation_fraction stuck_samples stuck_tolerance stuck_min_speed "
    "stuck_speed_fraction stuck_braking_deceleration gyro_max_step accel_max_step max_wheel_acceleration "
    "accel_consistency "
    "accel_consistency_per_speed consistency_samples fast_consistency_samples fast_consistency_factor "
    "bias_step_samples bias_step_yaw_rate yaw_slip_fraction yaw_witness_lag yaw_threshold "
    "encoder_readmission_samples encoder_readmission_fraction gyro_readmission_samples "
    "gyro_readmission_fraction clip_samples clip_window gain_threshold gain_tolerance gain_samples "
    "gain_block_samples gain_cross_coupling gain_offset_allowance gain_release "
    "radius_R radius_L track_width T_N encoder_step accelerometer_position max_wheel_speed gyro_noise_std "
    "accel_noise_std accel_vibration_per_speed accel_vibration_time_constant accel_initial_bias_std "
    "accel_drift_density tyre_peak_acceleration mass wheel_inertia motor_constant motor_current_limit "
    "bearing_drag shoe_offset "
    "shoe_friction shoe_viscous_drag shoe_slip_speed shoe_normal_load yaw_inertia wheel_normal_load "
    "tyre_friction tyre_stiffness_factor tyre_shape_factor slip_speed_floor",
)
"""What health_check reads: SensorHealthParameters' thresholds, then HealthGeometry (its max_wheel_speed
is the bound in force)."""
_GEOMETRY_FIELDS = HealthConstants._fields[HealthConstants._fields.index("radius_R") :]
FORCE_REFERENCE_FIELDS = HealthConstants._fields[HealthConstants._fields.index("mass") :]
"""HealthGeometry's figures of the nominal robot for the force reference and the yaw dynamics
(RobotParameters' names)."""
NO_VELOCITY = (math.nan, math.nan)
"""health_check's ``velocity`` when the navigation's estimate is not read: the odometric v_t, no v_n."""
NO_YAW_CALIBRATION = (0.0, 0.0)
"""health_check's ``yaw_calibration`` without a calibration: gyro bias 0, rolling-radius difference 0."""


def health_constants(p: SensorHealthParameters, g: HealthGeometry) -> tuple:
    """The parameters and the geometry as one plain tuple in HealthConstants' order (bool, int or float;
    accelerometer_position a pair of floats), as health_check takes them."""
    values = []
    for name in HealthConstants._fields:
        if name == "yaw_threshold":  # the yaw test's CUSUM threshold (systems/yaw_witness.py)
            values.append(yaw_test_threshold(p.yaw_false_alarm_time, g.T_N))
            continue
        value = getattr(g if name in _GEOMETRY_FIELDS else p, name)
        if name == "accelerometer_position":
            value = (float(value[0]), float(value[1]))
        elif name == "enabled":
            value = bool(value)
        elif name in (
            "stuck_samples",
            "consistency_samples",
            "fast_consistency_samples",
            "encoder_readmission_samples",
            "gyro_readmission_samples",
            "clip_samples",
            "clip_window",
            "gain_samples",
            "gain_block_samples",
            "bias_step_samples",
        ):
            value = int(value)
        else:
            value = float(value)
        values.append(value)
    return tuple(values)


def health_step(
    state,
    raw,
    p: SensorHealthParameters,
    g: HealthGeometry,
    currents=NO_CURRENTS,
    velocity=NO_VELOCITY,
    tyre_peak: float = math.nan,
    yaw_calibration=NO_YAW_CALIBRATION,
):
    """Check one sample (module docstring): health_check with ``p`` and ``g``; ``currents``: the motor
    drivers' readings [i_R, i_L] (A) of the sample; ``velocity``: the navigation's body velocity
    (v_t, v_n) of the previous sample (m/s) and ``tyre_peak`` its identified tyre peak (m/s^2; NaN: the
    nominal), for the excluded gyro's replacement; ``yaw_calibration``: the online calibration's
    [b_g, D] (systems/yaw_calibration.py) as it stood before the sample, which the replacements of the
    gyro and an encoder read.

    Returns:
        (next state, accepted sample [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L], health codes (7)).
    """
    return health_check(
        np.asarray(state, float),
        tuple([float(v) for v in raw]),
        (float(currents[0]), float(currents[1])),
        health_constants(p, g),
        (float(velocity[0]), float(velocity[1])),
        float(tyre_peak),
        (float(yaw_calibration[0]), float(yaw_calibration[1])),
    )


@compiled
def health_check(
    state,
    raw: tuple,
    currents: tuple,
    constants: tuple,
    velocity: tuple = NO_VELOCITY,
    tyre_peak: float = math.nan,
    yaw_calibration: tuple = NO_YAW_CALIBRATION,
):
    """health_step with the parameters and the geometry as health_constants' tuple, the sample, the
    currents, the velocity and the yaw calibration as tuples of floats and the tyre peak a float
    (compiled with numba when available: systems/compiled.py)."""
    p = g = HealthConstants(*constants)  # the parameters (p) and the geometry (g), one record
    bias, radius_difference = yaw_calibration  # b_g, D: what the replacements add to the nominal figures
    s = state.copy()
    if not p.enabled:  # NaN/inf only: hold the last valid value
        codes = [0 if math.isfinite(v) else NONFINITE for v in raw]
        out, ref = list(raw), s[_REF]
        for c in range(5):
            if codes[c]:
                out[c] = ref[c] if math.isfinite(ref[c]) else 0.0
            ref[c] = out[c]
        return s, out, codes
    ref, last, repeat, hold, excl = s[_REF], s[_LAST], s[_REPEAT], s[_HOLD], s[_EXCL]
    ring_pos = int(s[_RING_POS])
    codes = [0] * NUM_CHANNELS

    # Analog channels: non-finite, saturated, stuck, jump.
    ranges = (p.accel_range, p.accel_range, p.accel_range, p.accel_range, p.gyro_range)
    steps = (p.accel_max_step, p.accel_max_step, p.accel_max_step, p.accel_max_step, p.gyro_max_step)
    for c in range(5):
        x = raw[c]
        if not math.isfinite(x):
            codes[c] = NONFINITE
            continue
        same = math.isfinite(last[c]) and abs(x - last[c]) <= p.stuck_tolerance
        repeat[c] = repeat[c] + 1 if same else 0
        last[c] = x
        # At the data-sheet range, or at a rail below it (clip_returns: read only when needed)
        if abs(x) >= p.saturation_fraction * ranges[c] or (
            p.clip_samples > 0
            and clip_returns(s, _RING + CLIP_WINDOW_MAX * c, ring_pos, x, p) >= p.clip_samples
        ):
            codes[c] = SATURATED
        elif repeat[c] >= p.stuck_samples - 1:
            codes[c] = STUCK
        elif math.isfinite(ref[c]) and abs(x - (bias if c == 4 else 0.0) - ref[c]) > steps[c]:
            codes[c] = RECOVERING if excl[c] > 0 else JUMP
        elif hold[c] > 0:
            codes[c] = INCONSISTENT
    for c in range(5):  # the ring of readings (clip_returns)
        s[_RING + CLIP_WINDOW_MAX * c + ring_pos] = raw[c]
    s[_RING_POS] = (ring_pos + 1) % CLIP_WINDOW_MAX

    # An excluded gyro comes back only after a block of samples within its bound of the replacement whose
    # summed difference from it (a heading) stays within the noise, two counts of each wheel and
    # gyro_readmission_fraction of the replacement's own: a scale error does not telescope. A gyro the yaw
    # test holds out (hold[4]) is judged only once the block has turned YAW_RELEASE_HEADING.
    held = hold[4] > 0.0
    if (codes[4] == 0 or (held and codes[4] == INCONSISTENT)) and excl[4] > 0.0 and math.isfinite(ref[4]):
        out_code = INCONSISTENT if held else RECOVERING
        s[_G_COUNT] += 1.0
        s[_G_DIFF] += raw[4] - bias - ref[4]
        s[_G_TRAVEL] += abs(ref[4])
        informative = not held or s[_G_TRAVEL] * g.T_N >= YAW_RELEASE_HEADING
        if s[_G_COUNT] < p.gyro_readmission_samples or not informative:
            codes[4] = out_code
        else:
            n = s[_G_COUNT]
            counts = 4.0 * count_yaw_rate(g)  # two counts of each wheel
            allowed = (
                3.0 * g.gyro_noise_std * math.sqrt(n) + counts + p.gyro_readmission_fraction * s[_G_TRAVEL]
            )
            if abs(s[_G_DIFF]) > allowed:
                codes[4] = out_code  # a new block from the next sample
            else:
                codes[4], hold[4] = 0, 0.0
            s[_G_COUNT], s[_G_DIFF], s[_G_TRAVEL] = 0.0, 0.0, 0.0
    else:
        s[_G_COUNT], s[_G_DIFF], s[_G_TRAVEL] = 0.0, 0.0, 0.0
    gyro_bias_step_block(s, codes[4], raw[4] - bias - ref[4], ref[4], p, g)
    gyro_ok = codes[4] == 0

    # Encoders: raw-to-raw increments; implausible, spanning an exclusion, or still while predicted moving.
    radii = (g.radius_R, g.radius_L)
    e_last, e_out, e_inc = s[_E_LAST], s[_E_OUT], s[_E_INC]
    still, pred, pred_abs, e_code, lost = s[_E_STILL], s[_E_PRED], s[_E_ABS], s[_E_CODE], s[_E_LOST]
    e_raw = s[_E_RAW]
    r_count, r_diff, r_travel, r_moved = s[_R_COUNT], s[_R_DIFF], s[_R_TRAVEL], s[_R_MOVED]
    suspect = s[_R_SUSPECT]
    previous_out = [e_last[w] + e_out[w] for w in range(2)]  # e_out: the output less the last raw

    def predicted_increment(w: int, other_increment: float) -> float:
        """Wheel w's increment from the other wheel's and the gyro: v_R - v_L = b omega - D v_o in the
        nominal radii (the calibration's omega = omega_o + D v_o / b), v_o taken as the other wheel's."""
        o = 1 - w
        v_other = other_increment * radii[o] / g.T_N
        turn = g.track_width * (raw[4] - bias) - radius_difference * v_other
        return (v_other + (1.0 if w == 0 else -1.0) * turn) * g.T_N / radii[w]

    missed = [0.0, 0.0]
    inc = [math.nan, math.nan]
    first = [False, False]
    in_block = [False, False]  # this sample extended a re-admission block that is not judged yet
    inc_candidate = [math.nan, math.nan]  # the healthy wheels' raw increments, for re-admission
    for w in range(2):
        x = raw[5 + w]
        if e_code[w] == 0 and lost[w] == 0 and math.isfinite(x) and math.isfinite(e_last[w]):
            inc_candidate[w] = x - e_last[w]
    count_speed = 2.0 * g.encoder_step / g.T_N
    for w in range(2):
        x = raw[5 + w]
        if not math.isfinite(x):
            codes[5 + w] = NONFINITE
            continue
        if not math.isfinite(e_last[w]):  # the first reading: the output starts there
            e_last[w] = x
            e_out[w] = 0.0
            first[w] = True
            continue
        d, e_last[w] = x - e_last[w], x
        d_prev, e_raw[w] = e_raw[w], d
        bound = (p.max_wheel_acceleration * g.T_N / radii[w] + count_speed) * g.T_N
        if lost[w] > 0:
            codes[5 + w] = RECOVERING  # this increment spans the exclusion
        elif abs(d) * radii[w] / g.T_N > g.max_wheel_speed:
            codes[5 + w] = JUMP
        elif e_code[w] in (0, STUCK):
            if abs(d - e_inc[w]) > bound:
                codes[5 + w], suspect[w] = JUMP, 1.0
            else:
                inc[w] = d
        else:  # re-admission: agree with the prediction, else (none) with the last raw increment
            other = inc_candidate[1 - w]
            if math.isfinite(other) and gyro_ok:
                expected = predicted_increment(w, other)
                ok = abs(d - expected) <= bound
                suspect[w] = suspect[w] if ok else 1.0
                if ok:  # and over a block of samples, where the counts' quantisation telescopes
                    r_count[w] += 1.0
                    r_diff[w] += d - expected
                    r_travel[w] += abs(expected)
                    r_moved[w] += abs(d)
                    moved = r_moved[w] >= READMISSION_TRAVEL_COUNTS * g.encoder_step
                    if r_count[w] >= p.encoder_readmission_samples and (moved or suspect[w] == 0.0):
                        tolerance = 2.0 * g.encoder_step + p.encoder_readmission_fraction * r_travel[w]
                        ok = abs(r_diff[w]) <= tolerance
                        suspect[w] = suspect[w] if ok else 1.0
                    else:
                        ok, in_block[w] = False, True
            else:
                ok = abs(d - d_prev) <= bound
            if ok:
                inc[w], suspect[w] = d, 0.0
            else:
                codes[5 + w] = RECOVERING
    predicted = [
        predicted_increment(w, inc[1 - w]) if math.isfinite(inc[1 - w]) and gyro_ok else math.nan
        for w in range(2)
    ]
    # The body's deceleration from the healthy tangential accelerometers (NaN if neither is).
    a_body = math.nan
    if codes[0] == 0 and codes[2] == 0:
        a_body = 0.5 * (raw[0] + raw[2])
    elif codes[0] == 0 or codes[2] == 0:
        a_body = raw[0] if codes[0] == 0 else raw[2]
    for w in range(2):
        braking = math.isfinite(predicted[w]) and a_body * math.copysign(1.0, predicted[w]) < (
            -p.stuck_braking_deceleration
        )
        if inc[w] == 0.0 and e_code[w] == STUCK:
            codes[5 + w] = STUCK  # still stuck
        elif inc[w] == 0.0 and math.isfinite(predicted[w]) and not braking:
            still[w] += 1
            pred[w] += predicted[w]
            pred_abs[w] += abs(predicted[w])
            o = 1 - w
            v_other = abs(inc[o]) * radii[o] / g.T_N
            mean_pred = pred_abs[w] * radii[w] / (still[w] * g.T_N)
            if (
                still[w] >= p.stuck_samples
                and mean_pred > p.stuck_min_speed + p.stuck_speed_fraction * v_other
            ):
                codes[5 + w], suspect[w] = STUCK, 1.0
                missed[w] = pred[w] - predicted[w]  # the travel missed before the detection
        else:
            still[w] = pred[w] = pred_abs[w] = 0.0
            if math.isfinite(inc[w]) and e_code[w] == STUCK:
                codes[5 + w], inc[w] = RECOVERING, math.nan  # the stuck counter resumes with a lump

    # Encoder output: accepted increment, else the predicted one, else the last one.
    out = list(raw)
    previous_inc = (e_inc[0], e_inc[1])
    used = [0.0, 0.0]
    for w in range(2):
        if first[w]:
            used[w] = 0.0
        elif codes[5 + w] == 0 and math.isfinite(inc[w]):
            used[w] = inc[w]
        elif math.isfinite(predicted[w]):
            used[w] = predicted[w]
        else:
            used[w] = e_inc[w]
        if first[w] or (codes[5 + w] == 0 and used[w] == inc[w]):
            out[5 + w] = e_last[w] + e_out[w]  # the reading itself, less its offset from replacements
        elif math.isfinite(previous_out[w]):
            out[5 + w] = previous_out[w] + used[w] + missed[w]
            e_out[w] = out[5 + w] - e_last[w]
        else:
            out[5 + w] = math.nan
        lost[w] = 1.0 if codes[5 + w] in (NONFINITE, JUMP) else 0.0
        e_code[w] = codes[5 + w]
        e_inc[w] = e_inc[w] if first[w] else used[w]  # the first keeps the initial speed's increment
        if not in_block[w]:  # judged, broken, or no block: the next one starts anew
            r_count[w] = r_diff[w] = r_travel[w] = r_moved[w] = 0.0
    s[_RESTORED] = 1.0 if missed[0] != 0.0 or missed[1] != 0.0 else 0.0
    v_R, v_L = used[0] * radii[0] / g.T_N, used[1] * radii[1] / g.T_N
    v_o = 0.5 * (v_R + v_L)
    v_R, v_L = v_R + 0.5 * radius_difference * v_o, v_L - 0.5 * radius_difference * v_o  # calibrated
    omega_o = (v_R - v_L) / g.track_width  # omega_o + D v_o / b
    enc_ok = codes[5] == 0 and codes[6] == 0

    # The wheels' yaw rate for an excluded gyro: the body's, through the nominal yaw dynamics
    # (yaw_follow_step, from the replacement's last value), else the odometric one.
    omega_wheels = omega_o
    model = enc_ok and g.yaw_inertia > 0.0
    v_t, v_n = (velocity[0], velocity[1]) if math.isfinite(velocity[0] + velocity[1]) else (v_o, 0.0)
    # the identified tyre peak over the nominal curve's (NaN, none: the nominal curve)
    grip = tyre_peak / g.tyre_peak_acceleration if g.tyre_peak_acceleration > 0.0 else math.nan
    grip = grip if 0.0 < grip < math.inf else 1.0
    # A frozen gyro is trusted for stuck_samples - 2 repeats (stuck_samples - 1 equal readings): the
    # wheels' yaw rate runs through them from the last reading that changed, and the heading the repeats
    # missed against it is owed. When the stuck test flags the gyro, its replacement starts from there
    # and pays the heading back over stuck_samples samples. Anchored afresh after any exclusion.
    shadow = s[_G_SHADOW]
    previous_omega = ref[4]  # the pair's omega' differences against what it last used
    if codes[4] == 0 and repeat[4] == 0:
        s[_G_SHADOW], s[_G_OWED] = raw[4] - bias, 0.0
    elif codes[4] == 0 and math.isfinite(shadow) and enc_ok:
        s[_G_SHADOW] = yaw_follow_step(shadow, v_R, v_L, v_t, v_n, g, grip) if model else omega_o
        s[_G_OWED] += s[_G_SHADOW] - (raw[4] - bias)
    if codes[4] == STUCK and excl[4] == 0.0 and math.isfinite(shadow) and enc_ok:
        ref[4] = shadow
        s[_G_PAY_LEFT] = float(p.stuck_samples)
        s[_G_PAY_RATE] = s[_G_OWED] / p.stuck_samples
    if codes[4] != 0:
        s[_G_SHADOW], s[_G_OWED] = math.nan, 0.0
    if not gyro_ok and model and math.isfinite(ref[4]):
        omega_wheels = yaw_follow_step(ref[4], v_R, v_L, v_t, v_n, g, grip)

    # The wheels' witness of the gyro and the yaw test (systems/yaw_witness.py): a gyro whose yaw rate the
    # wheels do not confirm, and the pair does not side with, is held out (hold[4], inconsistent).
    # The wheels witness nothing while their tyres slide: the witness restarts from the gyro (else the
    # odometric yaw rate) when they grip again, and forgets that start within the tyres' lag.
    witness = s[_Y_WITNESS] if math.isfinite(s[_Y_WITNESS]) else omega_o
    gripping = enc_ok and tyre_grip(v_R, v_L, v_t, v_n, witness, g) >= GRIP_STIFFNESS_RATIO
    if gripping and not math.isfinite(s[_Y_WITNESS]) and codes[4] == 0:
        witness = raw[4] - bias
    s[_Y_WITNESS] = yaw_witness_step(witness, v_R, v_L, v_t, v_n, g, grip) if gripping else math.nan
    smooth = s[_Y_SMOOTH] if math.isfinite(s[_Y_SMOOTH]) else s[_Y_WITNESS]
    s[_Y_SMOOTH] = smooth + (s[_Y_WITNESS] - smooth) * min(1.0, g.T_N / p.yaw_witness_lag)
    witness_rate = (s[_Y_SMOOTH] - smooth) / g.T_N if math.isfinite(s[_Y_SMOOTH]) else 0.0
    if codes[4] == 0 and gripping and abs(s[_Y_WITNESS]) > p.bias_step_yaw_rate:  # a turn: the scale's
        test = s[_Y_TEST]
        if gyro_yaw_test(test, raw[4] - bias, s[_Y_WITNESS], witness_rate, s[_W + 12], abs(v_o), p):
            hold[4], codes[4], gyro_ok = 1.0, INCONSISTENT, False
            omega_wheels = s[_Y_WITNESS]
    else:
        s[_Y_TEST][YAW_CUSUM] = 0.0

    # The force reference of a_t: what the motors put on the ground (their currents less the wheels'
    # bearing drag and inertia) and the nominal shoe drag, over the nominal mass; unlike d v_o/dt it does
    # not slip. NaN without plausible currents (beyond 1.5 x the driver's limit, or none).
    a_force = math.nan
    plausible = PLAUSIBLE_CURRENT * g.motor_current_limit
    if g.mass > 0.0 and enc_ok and not (first[0] or first[1]):
        if abs(currents[0]) <= plausible and abs(currents[1]) <= plausible:  # False for NaN
            force = 0.0
            for w in range(2):
                rate = used[w] / g.T_N
                rate_dot = (used[w] - previous_inc[w]) / (g.T_N * g.T_N)
                torque = g.motor_constant * currents[w] - g.bearing_drag * rate - g.wheel_inertia * rate_dot
                force += torque / radii[w]
            force, _ = shoe_drag(v_o, 0.0, raw[4] - bias if gyro_ok else omega_wheels, g, force, 0.0)
            a_force = force / g.mass

    # Accelerometer pair: disagreement beyond the rotational terms, a moving average over
    # consistency_samples (hysteresis: flagged above the limit, cleared below half of it); the one that
    # moved more and lies farther from the kinematics is excluded. The yaw rate the rotational terms use
    # is the gyro's, else the wheels' (omega_wheels), else (saturated) the pair's own.
    px, py = g.accelerometer_position
    omega = raw[4] - bias if gyro_ok else omega_wheels
    full_scale = p.saturation_fraction * p.gyro_range
    pair_finite = (
        math.isfinite(raw[0]) and math.isfinite(raw[1]) and math.isfinite(raw[2]) and math.isfinite(raw[3])
    )
    w2 = pair_omega_squared(raw, (px, py)) if pair_finite else math.nan
    if math.isfinite(w2):  # the pair's omega^2, averaged
        s[_W + 12] += (w2 - s[_W + 12]) / p.consistency_samples
    if codes[4] == SATURATED:
        railed = abs(raw[4]) >= full_scale  # else clipped below the data sheet's range (a plateau)
        pair = math.sqrt(max(s[_W + 12], 0.0))
        beyond_wheels = pair > max(full_scale, PAIR_SPIN_MARGIN * abs(omega_o))  # a spin they miss
        if enc_ok and (not railed or (abs(omega_o) < full_scale and not beyond_wheels)):
            omega = omega_wheels  # the gyro reads beyond what the robot does (railed, or its scale)
        else:  # this sample's pair (the averaged one lags a spin's onset)
            this_sample = math.sqrt(max(w2, 0.0)) if math.isfinite(w2) else 0.0
            omega = math.copysign(max(full_scale if railed else abs(raw[4]), this_sample), raw[4])
    omega_dot = (omega - previous_omega) / g.T_N if math.isfinite(previous_omega) else 0.0
    rot = pair_rotational_difference(omega, (px, py))
    # Noisy per sample, but its integral is x omega (exact): the replacements carry it.
    rot_dot = (-2.0 * omega_dot * py, 2.0 * omega_dot * px)
    average, deviation, level = s[_W : _W + 2], s[_W + 4 : _W + 8], s[_W + 8 : _W + 12]
    limit = p.accel_consistency + p.accel_consistency_per_speed * abs(v_o)
    a_kin = ((v_o - s[_W + 3]) / g.T_N if math.isnan(a_force) else a_force, v_o * omega)
    known = gyro_ok and math.isfinite(ref[4])  # the gyro's omega' (the odometry's is coarse)
    # The fast test needs the gyro's omega' on this sample: a gyro trusted on the previous one too (the
    # first sample after a re-admission differences the gyro against its replacement, up to 250 rad/s^2).
    fast_known = known and excl[4] == 0.0
    for axis in (0, 1):  # the pair's offset drifts with the two biases (pair_offset_update)
        s[_OFFSET_VAR + axis] += 2.0 * g.accel_drift_density**2 * g.T_N
    if _all_in(codes[0:4], (0, INCONSISTENT)):
        for c in range(4):
            deviation[c] += (raw[c] - a_kin[c % 2] - deviation[c]) / p.consistency_samples
            if not math.isfinite(level[c]):
                level[c] = raw[c]
        for axis in (0, 1):
            pair_of = (axis, axis + 2)  # sensor 1's and sensor 2's channel of this axis
            disagreement = raw[axis] - raw[axis + 2] - rot[axis] - rot_dot[axis]
            offset_free = disagreement - s[_OFFSET + axis]  # less the two biases' learned difference
            average[axis] += (offset_free - average[axis]) / p.consistency_samples
            if fast_known:
                s[_FAST + axis] += (offset_free - s[_FAST + axis]) / p.fast_consistency_samples
            else:  # the replacement's omega' is not averaged in: restart from the slow average
                s[_FAST + axis] = average[axis]
            fast = fast_pair_ratio(s[_FAST + axis], limit, axis, fast_known, p, g)  # 0: off, or no gyro
            mean = 0.5 * (raw[axis] + raw[axis + 2])
            other = 0.5 * (raw[1 - axis] + raw[3 - axis])
            # learned with the gyro's omega' on this sample (fast_known), both axes healthy and agreeing
            if fast_known and codes[axis] == 0 and codes[axis + 2] == 0 and abs(average[axis]) < 0.25 * limit:
                pair_offset_update(s, axis, disagreement, abs(v_o), other, p, g)
            rotation = rot[axis] + rot_dot[axis]
            moving = used[0] != 0.0 or used[1] != 0.0  # the wheels turned
            gain = pair_gain_ratio(
                s, axis, offset_free, mean, rotation, other, abs(v_o), moving, fast_known, p, g
            )
            held = hold[axis] != 0.0 or hold[axis + 2] != 0.0
            if abs(average[axis]) < 0.5 * limit and not held:  # each sensor's level while the pair agrees
                for c in pair_of:
                    level[c] += (raw[c] - level[c]) / p.consistency_samples
            averages_flag = abs(average[axis]) > limit or fast > limit
            if averages_flag:  # the averages' evidence (a bias) takes over a hold of the gain test's
                for c in pair_of:
                    hold[c] = 1.0 if hold[c] == GAIN_HOLD else hold[c]
            if (averages_flag or gain > 1.0) and not held:
                # Blame the one that moved more from its level before the pair began to disagree plus
                # the farther from the kinematics (each alone errs: the true signal moves meanwhile;
                # one encoder count in T_N is 3.8 m/s^2 of Tinyphoon's d v_o/dt, and the wheels slip).
                # With the force reference (t, currents read) the distance alone: it does not slip,
                # and the true signal's own change (a hard braking) would blame the healthy one. The
                # distance alone too when only the gain test flags: a scale fault grows with the
                # signal, and one sample's move from the level is mostly the commotion (the toleranced
                # closed corner's x2 accel2_n in the slide blamed accel1_n: 12.7 x).
                distance_only = (axis == 0 and not math.isnan(a_force)) or not averages_flag
                score = [abs(deviation[c]) for c in pair_of]
                if not distance_only:
                    score = [score[i] + abs(raw[pair_of[i]] - level[pair_of[i]]) for i in range(2)]
                bad = pair_of[0] if score[0] > score[1] else pair_of[1]
                hold[bad] = 1.0 if averages_flag else GAIN_HOLD
                codes[bad] = INCONSISTENT
            # A hold by the gain test alone (GAIN_HOLD) is released when its evidence of the fault is gone
            # and that of a gain within gain_release is in; the averages' hold (1) when theirs is gone.
            elif (
                held
                and abs(average[axis]) < 0.5 * limit
                and fast < 0.5 * limit
                and gain < 0.5
                and (
                    max(hold[axis], hold[axis + 2]) != GAIN_HOLD
                    or pair_gain_upper_bound(s, axis, fast_known, p) < p.gain_release
                )
            ):
                for c in pair_of:
                    hold[c] = 0.0
                    codes[c] = 0 if codes[c] == INCONSISTENT else codes[c]
    else:  # an axis out of the pair for its own fault: the gain test's window is stale when it returns
        pair_gain_reset(s)
    s[_W + 3] = v_o

    # Analog output: the reading, else its redundant estimate (the reference carried along).
    for c in range(5):
        if codes[c] == 0:  # the reference is the gyro less b_g, as its replacement is
            out[c] = raw[c]
            ref[c] = raw[c] - (bias if c == 4 else 0.0)
            excl[c] = 0.0
            continue
        excl[c] += 1.0
        if c == 4 and codes[4] == SATURATED:
            value = omega  # the pair's yaw rate, or the wheels' (above)
        elif c == 4:
            value = omega_wheels if enc_ok else ref[4]
        elif codes[c ^ 2] == 0:
            value = raw[c ^ 2] + (1.0 if c < 2 else -1.0) * (rot[c % 2] + rot_dot[c % 2] + s[_OFFSET + c % 2])
        else:
            value = ref[c]
        out[c] = ref[c] = value if math.isfinite(value) else 0.0
        if c == 4:  # the body's yaw rate as the gyro would read it: its bias, which the navigation removes
            out[4] += bias
    if s[_G_PAY_LEFT] > 0.0:  # a frozen gyro's owed heading, re-admitted or not (the reference goes without)
        out[4] += s[_G_PAY_RATE]
        s[_G_PAY_LEFT] -= 1.0
    return s, out, codes


@jitable
def clip_returns(s, base: int, position: int, x: float, p) -> int:
    """How many times reading ``x`` returned to its magnitude within the last clip_window readings (the
    ring s[base : base + CLIP_WINDOW_MAX], the next slot at ``position``) since the last larger one,
    counting this one and a run of repeats once. A clipped channel returns to its rail again and again,
    the largest magnitude it reads; noise never repeats a value (within stuck_tolerance)."""
    tol = p.stuck_tolerance
    runs, newer_at = 1, True  # this reading is at its own magnitude
    for j in range(1, p.clip_window):
        y = s[base + (position - j) % CLIP_WINDOW_MAX]
        if not math.isfinite(y):  # a gap does not split a run
            continue
        if abs(y) > abs(x) + tol:
            break
        at = abs(abs(y) - abs(x)) <= tol
        if at and not newer_at:
            runs += 1
        newer_at = at
    return runs


@jitable
def gyro_bias_step_block(s, code: int, residual: float, replacement: float, p, g) -> None:
    """The bias step of an excluded gyro (module docstring, re-admission): while the gyro is out for a
    jump (JUMP, RECOVERING), its ``residual`` against the ``replacement`` (raw - b_g - replacement, rad/s)
    is summed over blocks of bias_step_samples. A block in which the replacement stays within
    bias_step_yaw_rate (the wheels say the robot drives straight, where a yaw-rate scale error reads
    nothing) and the residual's standard deviation within BIAS_STEP_SIGMAS of the gyro's noise plus the
    wheels' quantisation (one count of each wheel over T_N, as a yaw rate) measures a new bias: its mean
    residual, unless within BIAS_STEP_SIGMAS of its standard error, is handed to the calibration
    (s[_B_STEP], gyro_bias_step), which adds it to b_g; the gyro is then re-admitted by the block test
    when it agrees again."""
    s[_B_STEP] = 0.0
    if code != JUMP and code != RECOVERING or not math.isfinite(residual):
        s[_B_COUNT] = s[_B_SUM] = s[_B_SQUARES] = s[_B_TURN] = 0.0
        return
    s[_B_COUNT] += 1.0
    s[_B_SUM] += residual
    s[_B_SQUARES] += residual * residual
    s[_B_TURN] = max(s[_B_TURN], abs(replacement))
    n = s[_B_COUNT]
    if n < p.bias_step_samples:
        return
    mean = s[_B_SUM] / n
    spread = math.sqrt(max(s[_B_SQUARES] / n - mean * mean, 0.0))
    counts = 2.0 * count_yaw_rate(g)  # one count of each wheel
    measured = abs(mean) > BIAS_STEP_SIGMAS * max(spread, g.gyro_noise_std) / math.sqrt(n)
    steady = spread <= BIAS_STEP_SIGMAS * g.gyro_noise_std + counts
    if s[_B_TURN] <= p.bias_step_yaw_rate and steady and measured:
        s[_B_STEP] = mean
    s[_B_COUNT] = s[_B_SUM] = s[_B_SQUARES] = s[_B_TURN] = 0.0


def gyro_bias_step(state) -> float:
    """The gyro bias step (rad/s) the checks of this sample hand to the calibration (0: none;
    gyro_bias_step_block)."""
    return float(state[_B_STEP])


@jitable
def pair_offset_update(s, axis: int, disagreement: float, speed: float, other: float, p, g):
    """Learns the pair's offset a_1 - a_2 beyond the rotational terms on ``axis`` (the bias difference)
    from one sample's ``disagreement``: a scalar Kalman filter in s[_OFFSET + axis], its variance in
    s[_OFFSET_VAR + axis] (from 2 accel_initial_bias_std^2; health_check adds 2 accel_drift_density^2
    T_N every sample, the two biases' random walk). The sample weighs by the disagreement's noise: white,
    the commotion at ``speed`` (S(3)'s Gauss-Markov process, its correlation counted as (1 + phi)/(1 - phi)
    samples) and gain_cross_coupling of the ``other`` axis's acceleration (misalignment). The omega' noise
    of the rotational terms (the gyro's difference) is left out: it telescopes over the filter's
    near-equal weights. At rest the offset's standard deviation falls to 0.01 m/s^2 in 0.15 s; at speed
    the commotion moves it little (a PT1 of 1 s wandered 0.05 m/s^2 in the corner's slide)."""
    phi = math.exp(-g.T_N / g.accel_vibration_time_constant)
    commotion = g.accel_vibration_per_speed * speed
    noise = (
        2.0 * g.accel_noise_std**2
        + 2.0 * commotion**2 * (1.0 + phi) / (1.0 - phi)
        + (p.gain_cross_coupling * other) ** 2
    )
    if not s[_OFFSET_VAR + axis] + noise > 0.0:  # a noiseless data sheet and no motion: nothing to weigh
        return
    gain = s[_OFFSET_VAR + axis] / (s[_OFFSET_VAR + axis] + noise)
    s[_OFFSET + axis] += gain * (disagreement - s[_OFFSET + axis])
    s[_OFFSET_VAR + axis] *= 1.0 - gain


@jitable
def averaged_omega_dot_std(gain: float, g) -> float:
    """The noise of omega' from the gyro's sample-to-sample difference after an exponential average with
    ``gain`` (1/n): sigma g sqrt(1 + g / (2 - g)) / T_N, sigma the gyro's white noise."""
    return gain * g.gyro_noise_std / g.T_N * math.sqrt(1.0 + gain / (2.0 - gain))


@jitable
def fast_pair_ratio(fast_average: float, limit: float, axis: int, known: bool, p, g) -> float:
    """The fast pair test's average over its bound, in units of the slow test's bound ``limit`` (module
    docstring, 5.; > limit flags): the bound is fast_consistency_factor x limit plus FAST_ROTATION_SIGMAS
    of the noise that omega' from the gyro's difference puts into the average's rotational term (the
    average of a difference over fast_consistency_samples n: averaged_omega_dot_std with g = 1/n, times
    the lever 2 y for t, 2 x for n). 0 while the test is off or the gyro is not
    trusted (the odometry's omega' is one count's 55 rad/s^2 a sample on Tinyphoon)."""
    if not known or math.isinf(p.fast_consistency_factor):
        return 0.0
    gain = 1.0 / p.fast_consistency_samples
    omega_dot_std = averaged_omega_dot_std(gain, g)
    lever = abs(g.accelerometer_position[1 - axis])  # t: y, n: x
    bound = p.fast_consistency_factor * limit + FAST_ROTATION_SIGMAS * 2.0 * lever * omega_dot_std
    return abs(fast_average) / bound * limit


GAIN_CORRELATION = 16.0
"""The gain test's sums add neighbouring samples whose noise is correlated (the block averages, the
commotion's 5 ms): the variance of a sum is taken as this many times that of independent samples. Set on
the built-ins' fault-free runs (SensorHealthParameters.gain_threshold)."""

GAIN_HORIZON = 2
"""The gain test's evidence is at most this many times gain_samples samples old: a standstill after a
fault (nothing informative comes in) re-admits the sensor within it (80 samples, 0.16 s)."""


@jitable
def pair_gain_ratio(
    s, axis: int, disagreement, mean, rotation, other, speed, moving: bool, update: bool, p, g
) -> float:
    """The accelerometer pair's gain test on ``axis`` (0: t, 1: n), its statistic over gain_threshold (> 1
    flags; 0 while off or not ``update``d). A scale fault on one sensor makes the pair's disagreement
    (beyond S(3)'s rotational terms and the learned offset) proportional to its signal, which the averages
    of the consistency test miss while it stays below their bound (the open corner's tangential axes:
    1 m/s^2 on average, the bound 2.6 m/s^2 at speed). Updated in place in ``s`` while ``update`` (the
    gyro's omega' is known): the disagreement and the regressors are averaged over gain_block_samples;
    the gain beta of the disagreement on each regressor r = mean +- rotation / 2 (sensor 1's or sensor 2's
    own signal; the mean's noise is uncorrelated with the disagreement's) is the ratio of the sums of
    d r / var and r^2 / var over the last gain_samples informative samples (the wheels turned,
    ``moving``: at rest the mean is the sensors' biases; and a regressor above the noise) within the last
    GAIN_HORIZON gain_samples samples, var the noise of the averaged disagreement (white and commotion at
    ``speed`` as the block average leaves them, omega' from the gyro's difference on the lever, the other
    axis's acceleration times gain_cross_coupling). The statistic is (|beta| - gain_tolerance -
    gain_offset_allowance sum |r| / var / sum r^2 / var) over beta's standard deviation
    sqrt(GAIN_CORRELATION / sum r^2 / var), the larger of the two regressors'; the allowance is what an
    offset error of the disagreement puts into beta."""
    if math.isinf(p.gain_threshold) or not update:
        return 0.0
    base = _GAIN + GAIN_SLOTS * axis
    b = 1.0 / p.gain_block_samples
    s[base] += (disagreement - s[base]) * b
    s[base + 1] += (mean - s[base + 1]) * b
    s[base + 2] += (0.5 * rotation - s[base + 2]) * b
    s[base + 3] += (other - s[base + 3]) * b
    phi = math.exp(-g.T_N / g.accel_vibration_time_constant) * (1.0 - b)
    white = b / (2.0 - b)  # an exponential average's variance over its input's
    coloured = white * (1.0 + phi) / (1.0 - phi)  # the same for the commotion (first order)
    omega_dot_std = averaged_omega_dot_std(b, g)
    lever = abs(g.accelerometer_position[1 - axis])  # t: y, n: x
    commotion = g.accel_vibration_per_speed * speed
    variance = (
        (p.gain_cross_coupling * s[base + 3]) ** 2
        + 2.0 * g.accel_noise_std**2 * white
        + 2.0 * commotion**2 * coloured
        + (2.0 * lever * omega_dot_std) ** 2
    )
    # The window holds the last gain_samples informative samples of the last GAIN_HORIZON gain_samples
    # samples: a signal's zero crossing keeps the evidence, a standstill lets it expire. Each sample's
    # products replace the oldest in the ring and in the sums (recomputed from the ring whenever it
    # wraps, against rounding). Per regressor k the sums d r / var, r^2 / var, |r| / var.
    n = p.gain_samples
    ring = _GAIN_RING + axis * (GAIN_SERIES + 1) * GAIN_WINDOW_MAX  # the products, then sample numbers
    numbers = ring + GAIN_SERIES * GAIN_WINDOW_MAX
    s[base + 4 + GAIN_SERIES] += 1.0  # this sample's number
    position, count = int(s[_GAIN_POS + axis]), int(s[base + 5 + GAIN_SERIES])
    while count > 0:  # expire the oldest entries
        oldest = (position - count) % n
        if s[numbers + oldest] > s[base + 4 + GAIN_SERIES] - GAIN_HORIZON * n:
            break
        for i in range(GAIN_SERIES):
            s[base + 4 + i] -= s[ring + i * GAIN_WINDOW_MAX + oldest]
            s[ring + i * GAIN_WINDOW_MAX + oldest] = 0.0
        count -= 1
    if count == 0:
        for i in range(GAIN_SERIES):
            s[base + 4 + i] = 0.0
    regressors = (s[base + 1] + s[base + 2], s[base + 1] - s[base + 2])
    if moving and variance > 0.0 and max(regressors[0] ** 2, regressors[1] ** 2) > variance:
        for k in range(2):
            r = regressors[k]
            products = (s[base] * r / variance, r * r / variance, abs(r) / variance)
            for j in range(3):
                series = 3 * k + j
                slot = ring + series * GAIN_WINDOW_MAX + position
                s[base + 4 + series] += products[j] - s[slot]
                s[slot] = products[j]
                if position == n - 1:
                    start, total = ring + series * GAIN_WINDOW_MAX, 0.0
                    for i in range(n):  # in order (np.sum's pairwise order is not numba's)
                        total += s[start + i]
                    s[base + 4 + series] = total
        s[numbers + position] = s[base + 4 + GAIN_SERIES]
        position, count = (position + 1) % n, min(count + 1, n)
    s[_GAIN_POS + axis], s[base + 5 + GAIN_SERIES] = float(position), float(count)
    worst = 0.0
    for k in range(2):
        energy = s[base + 5 + 3 * k]
        if energy > 0.0:
            beta = s[base + 4 + 3 * k] / energy
            allowance = p.gain_tolerance + p.gain_offset_allowance * s[base + 6 + 3 * k] / energy
            spread = math.sqrt(GAIN_CORRELATION / energy)
            worst = max(worst, max(abs(beta) - allowance, 0.0) / spread)
    return worst / p.gain_threshold


@jitable
def pair_gain_reset(s):
    """Empties the gain test's windows and block averages (both axes): while an accelerometer is out for
    its own fault (NaN, saturated, stuck, jumping) the pair is not judged, and the evidence from before it
    is stale when it returns. Kept, the window flagged the toleranced closed corner's pair (seed 4) two
    samples after a frozen accel2_t came back, and blamed accel1_t for 0.43 s."""
    for axis in range(2):
        base = _GAIN + GAIN_SLOTS * axis
        if s[base + 5 + GAIN_SERIES] == 0.0 and s[_GAIN_POS + axis] == 0.0 and s[base] == 0.0:
            if s[base + 1] == 0.0 and s[base + 2] == 0.0 and s[base + 3] == 0.0:
                continue  # emptied already (an empty window's ring holds no products): not every sample
        for i in range(GAIN_SLOTS):
            if i != 4 + GAIN_SERIES:  # the sample counter runs on
                s[base + i] = 0.0
        ring = _GAIN_RING + axis * (GAIN_SERIES + 1) * GAIN_WINDOW_MAX
        for i in range(GAIN_SERIES * GAIN_WINDOW_MAX):
            s[ring + i] = 0.0
        s[_GAIN_POS + axis] = 0.0


GAIN_HOLD = 2.0
"""A pair's hold (the state's inconsistency hold) set by the gain test alone; the averages' is 1."""
GAIN_RELEASE_SIGMAS = 1.0
"""The gain test's upper bound on a gain (pair_gain_upper_bound): this many standard deviations above."""


@jitable
def pair_gain_upper_bound(s, axis: int, update: bool, p) -> float:
    """The gain test's evidence of health on ``axis`` after pair_gain_ratio's update: the larger regressor's
    |beta| + GAIN_RELEASE_SIGMAS standard deviations (0: nothing informative in the window, or not
    ``update``d, or the test off). A pair the gain test flagged is released when this is below
    gain_release: a flag is cleared by the evidence of a gain within it, not by a window whose evidence
    of the fault dipped (a doubled sensor's beta of 0.67 read 0.38, 2 sigmas low, on 40 samples)."""
    if math.isinf(p.gain_threshold) or not update:
        return 0.0
    base = _GAIN + GAIN_SLOTS * axis
    upper = 0.0
    for k in range(2):
        energy = s[base + 5 + 3 * k]
        if energy > 0.0:
            beta = s[base + 4 + 3 * k] / energy
            upper = max(upper, abs(beta) + GAIN_RELEASE_SIGMAS * math.sqrt(GAIN_CORRELATION / energy))
    return upper


@jitable
def _all_in(values, allowed) -> bool:
    """Every one of ``values`` is one of ``allowed``."""
    for value in values:
        if value not in allowed:
            return False
    return True


@jitable
def pair_rotational_difference(omega: float, position) -> tuple:
    """S(3)'s centripetal difference of the accelerometer pair at +-(x, y), (a_t1 - a_t2, a_n1 - a_n2)
    without the angular-acceleration terms: (-2 omega^2 x, -2 omega^2 y)."""
    x, y = position
    return (-2.0 * omega * omega * x, -2.0 * omega * omega * y)


@jitable
def pair_omega_squared(sample, position) -> float:
    """omega^2 from the accelerometer pair at +-(x, y) (S(3)'s rotational terms):
    a_t1 - a_t2 = -2 (omega_dot y + omega^2 x), a_n1 - a_n2 = 2 (omega_dot x - omega^2 y), so
    omega^2 = -(x (a_t1 - a_t2) + y (a_n1 - a_n2)) / (2 (x^2 + y^2)): a yaw-rate sensor without a range."""
    x, y = position
    return -(x * (sample[0] - sample[2]) + y * (sample[1] - sample[3])) / (2.0 * (x * x + y * y))


def health_report(t, arrays: dict, channels) -> dict:
    """Per flagged channel of a run: the first flagged time (s), the flagged samples, and the samples of
    each class; ``arrays[f"health_{channel}"]`` hold the codes."""
    report = {}
    for channel in channels:
        codes = np.asarray(arrays[f"health_{channel}"])
        flagged = np.flatnonzero(codes > 0)
        if len(flagged) == 0:
            continue
        report[channel] = {
            "first_s": float(t[flagged[0]]),
            "samples": int(len(flagged)),
            "classes": {
                name: int(np.sum(codes == k + 1))
                for k, name in enumerate(HEALTH_CLASSES)
                if np.any(codes == k + 1)
            },
        }
    return report


HEALTH_STEP_LAYOUT = (
    ("state", STATE_SIZE),
    ("accelerometers", 4),
    ("gyro", 1),
    ("encoders", 2),
    ("health", NUM_CHANNELS),
    ("inertial_fault", 1),
    ("encoder_fault", 1),
    ("sensor_fault", 1),
    ("gyro_bias_step", 1),
)
"""The SensorHealthMonitor's ``step`` output, in order: (name, size); diagrams/split.py slices it."""


def slip_detector_blind(codes, unusable: bool = False) -> bool:
    """S(11) cannot use the sample: both encoders excluded, one encoder excluded while the gyro is (its
    replacement is then its last increment, not the other wheel's and the gyro's), an encoder output that
    cannot serve (``unusable``, odometry_unusable: a stuck encoder's missed travel restored in this one
    sample, or a non-finite angle that the odometry holds over), or both tangential accelerometers
    excluded.

    An encoder excluded otherwise advances by the other wheel's increment and the gyro's yaw rate (v_R -
    v_L = b omega): the odometric v_t is then the healthy wheel's, and its slip is what S(11) is there to
    see (a braking slide during an encoder outage: open square, C1 would otherwise return to the
    odometry; a stuck encoder: C1 recovers from the slip the still counts feigned before the detection).
    One excluded tangential axis reads its partner's plus the rotational terms (the replacement), which
    S(11) uses: isolated by the force reference, it is the healthy sensor's reading; a gyro or lateral
    fault alone does not touch S(11)."""
    right, left = codes[5] > 0, codes[6] > 0
    if unusable or (right and left) or ((right or left) and codes[4] > 0):
        return True
    return codes[0] > 0 and codes[2] > 0


def travel_restored(state) -> bool:
    """This sample's encoder output restored a stuck encoder's missed travel (health_check's state)."""
    return state[_RESTORED] > 0.0


def odometry_unusable(state, sample) -> bool:
    """This sample's encoder output cannot serve S(11) (slip_detector_blind): it restores a stuck
    encoder's missed travel (travel_restored), or an angle is not finite (the checks off, or no reading
    yet), so that the odometry holds its last speed over it."""
    return travel_restored(state) or not (math.isfinite(sample[5]) and math.isfinite(sample[6]))


def health_flags(codes, unusable: bool = False) -> list:
    """[inertial_fault, encoder_fault, sensor_fault]: 1.0 when any accelerometer/gyro, any encoder is
    excluded (codes > 0), when S(11) cannot use the sample (slip_detector_blind)."""
    inertial = 1.0 if max(codes[0:5]) > 0 else 0.0
    encoder = 1.0 if max(codes[5:7]) > 0 else 0.0
    return [inertial, encoder, 1.0 if slip_detector_blind(codes, unusable) else 0.0]


class SensorHealthMonitor(LeafSystem):
    """Checks every sensor channel, excludes and replaces the faulty ones (module docstring).

    .. pydrake_system::

        name: SensorHealthMonitor
        input_ports:
        - accelerometers
        - gyro
        - encoders
        - motor_currents
        - body_velocity
        - tyre_peak
        - yaw_calibration
        output_ports:
        - step

    - inputs: the samples as read; motor_currents (optional): the drivers' current readings [i_R, i_L]
      (A), the t axes' force reference (unconnected: the odometry's); body_velocity (optional): the
      navigation's (v_t, v_n) of the previous sample (the EKF's state), which the excluded gyro's
      replacement reads (yaw_follow_step; unconnected: the odometric v_t and no v_n); tyre_peak
      (optional): the navigation's identified tyre peak of the previous sample (the velocity mixer's
      state; unconnected: the nominal); yaw_calibration (optional): the online calibration's [b_g, D]
      (the YawRateCalibration's state; unconnected: 0, 0), with which the gyro's replacement reads the
      calibrated odometric yaw rate omega_o + D v_o / b plus the bias, and an encoder's v_R - v_L = b
      (gyro - b_g) - D v_o.
    - step (direct feedthrough), in HEALTH_STEP_LAYOUT's order: the next state; the accepted or replaced
      samples accelerometers [a_t1, a_n1, a_t2, a_n2], gyro [omega], encoders [theta_R, theta_L]; health,
      the code of each channel [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L] (0 healthy,
      k: HEALTH_CLASSES[k - 1]); inertial_fault, encoder_fault: 1 when any accelerometer/gyro, any
      encoder channel is excluded (the yaw calibration does not learn from the sample); sensor_fault:
      S(11) cannot use the sample (slip_detector_blind: both encoders, one while the gyro is excluded, a
      stuck one's restored travel, or both tangential accelerometers; its sum leaves the sample out).
      gyro_bias_step: the step of b_g measured on an excluded gyro this sample (rad/s, 0: none;
      gyro_bias_step_block), for the calibration. One vector, so that one Python call per sample
      computes them all; the navigation diagram slices it with a Demultiplexer (diagrams/split.py).

    Update every T_N: health_step's state.

    Args:
        params: SensorHealthParameters. geometry: HealthGeometry. initial_speed: wheels' speed before t=0.
    """

    def __init__(self, params: SensorHealthParameters, geometry: HealthGeometry, initial_speed: float = 0.0):
        super().__init__()
        params.__post_init__()
        self._p, self._g = params, geometry
        self._constants = health_constants(params, geometry)
        self._inputs = [
            self.DeclareVectorInputPort(name, size)
            for name, size in (("accelerometers", 4), ("gyro", 1), ("encoders", 2))
        ]
        self._currents = self.DeclareVectorInputPort("motor_currents", 2)
        self._velocity = self.DeclareVectorInputPort("body_velocity", 2)
        self._tyre_peak = self.DeclareVectorInputPort("tyre_peak", 1)
        self._yaw_calibration = self.DeclareVectorInputPort("yaw_calibration", 2)
        self._state = self.DeclareDiscreteState(health_initial_state(geometry, initial_speed))
        prereq = {
            self.xd_ticket(),
            self._currents.ticket(),
            self._velocity.ticket(),
            self._tyre_peak.ticket(),
            self._yaw_calibration.ticket(),
        }
        prereq |= {port.ticket() for port in self._inputs}
        size = sum(n for _, n in HEALTH_STEP_LAYOUT)
        self._step = self.DeclareVectorOutputPort("step", size, self._calc, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(geometry.T_N, 0.0, self._update)

    def _calc(self, context, output):
        raw = tuple([v for port in self._inputs for v in port.Eval(context).tolist()])
        state = context.get_discrete_state(self._state).get_value()
        port = self._currents
        currents = tuple(port.Eval(context).tolist()) if port.HasValue(context) else NO_CURRENTS
        port = self._velocity
        velocity = tuple(port.Eval(context).tolist()) if port.HasValue(context) else NO_VELOCITY
        port = self._tyre_peak
        peak = float(port.Eval(context)[0]) if port.HasValue(context) else math.nan
        port = self._yaw_calibration
        calibration = tuple(port.Eval(context).tolist()) if port.HasValue(context) else NO_YAW_CALIBRATION
        state, out, codes = health_check(state, raw, currents, self._constants, velocity, peak, calibration)
        step = output.get_mutable_value()  # written in place: no list of the whole vector
        step[0:STATE_SIZE] = state
        flags = health_flags(codes, odometry_unusable(state, out))
        step[STATE_SIZE:] = [*out, *codes, *flags, gyro_bias_step(state)]

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._state, self._step.Eval(context)[0:STATE_SIZE])
