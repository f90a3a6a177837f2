"""The wheels' witness of the gyro: the body's yaw rate the wheels imply, and one test of the gyro
against it, the accelerometers breaking the tie (two against one).

1. The witness (yaw_witness_step): the nominal yaw dynamics driven by the wheels' circumferential speeds
   (yaw_follow_step), from the wheels alone: the body's yaw rate lags the wheels' kinematic one by the
   tyres' slip. Without the nominal robot's yaw inertia (yaw_lag_at_floor) it is the odometric yaw rate.
2. The residual r = (gyro - b_g) - witness, normalised by its predicted variance (yaw_residual_variance)
   and by the larger of 1 and the spread the healthy samples show (Mehra's innovation-based estimate: a
   robot whose witnesses agree less well than the data sheet says raises no alarm for that), is judged
   in turns (|witness| beyond bias_step_yaw_rate; below it the calibration judges the bias) by a
   two-sided CUSUM (systems/residual_test.py; drift YAW_DRIFT, clip YAW_CLIP, threshold from
   yaw_false_alarm_time of healthy samples): a gyro whose scale is off by 50 % in a 3 rad/s turn moves
   z by 2.5 and raises the alarm within 10 ms. Outside turns, and while the tyres slide (tyre_grip below
   GRIP_STIFFNESS_RATIO along their rolling direction: the wheels witness nothing), the sums restart; the
   witness restarts from the gyro when the tyres grip again and forgets that start within the tyres'
   lag. The side slip is left out of both: the navigation's v_n integrates the gyro under test.
3. The decision (gyro_yaw_test): on an alarm the third witnesses weigh the two hypotheses "the gyro is
   right" and "the wheels are right" by their log-likelihood ratio (side_log_likelihood), summed over
   the witnesses present:
   - the lateral acceleration (lateral_update): the accelerometers' a_n at the pair's centre is
     v_t omega + v_n' (the centripetal term, S(3)), so the averages of a_n - v_t omega under each
     hypothesis, over the same samples, lie near zero for the right one (lateral_variance: the noise
     and commotion averaged, the accelerometers' initial bias, and the side slip's v_n'); it reads the
     sign of omega, and its weight grows with the speed;
   - the pair's omega^2 (S(3)'s centripetal difference, averaged, less its learned offset's share;
     pair_squared_variance), whose weight falls with the speed (the commotion).
   The gyro stays in when the ratio favours it by SIDE_LOG_LIKELIHOOD (the wheels slide or are held:
   the perturbation monitor's matter); otherwise it is blamed. Without any third witness two witnesses
   disagree and neither can be isolated: the gyro stays in and the sums restart.
4. The verdict (yaw_test_verdict): a judged sample without an alarm confirms the gyro when the sums hold
   no evidence against it over a judged turn of a stated heading (the caller's YAW_RELEASE_HEADING).
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.residual_test import CUSUM_SIZE, CusumTest, cusum_update
from slipnav.systems.robot.contact import shoe_drag, tyre_force_and_stiffness
from slipnav.systems.state_layout import layout_size, layout_slices

YAW_DRIFT = 0.5
"""The yaw test's CUSUM drift k (sigma): soonest for a shift of one sigma."""
YAW_CLIP = 4.0
"""|z| beyond this counts as this (sigma): one sample moves the sums by at most 3.5 sigma, so an alarm
needs four samples at least."""
GRIP_STIFFNESS_RATIO = 0.5
"""The wheels witness the body's yaw rate only while both tyres' slip stiffness dF/dslip is at least this
share of its value at zero slip (tyre_grip): past the peak the wheels turn apart while the body does
not (the square's braking slides)."""
MIN_YAW_LAG_STEPS = 0.25
"""The nominal yaw dynamics serve as the witness only while their lag at the tyres' slip-speed floor is at
least this many T_N (yaw_lag_at_floor): Tinyphoon 1.1, Kurt3D 0.9; a TurtleBot's track with Tinyphoon's
yaw inertia 0.1."""
LATERAL_SLIP_FRACTION = 0.1
"""The side slip's v_n' in the lateral witness, as a share of v_t omega (one sigma): the nominal tyres'
transients in the corner's 3 rad/s turns reach 0.2 of it (95th percentile), the square's 0.03."""
SIDE_LOG_LIKELIHOOD = 2.0
"""The third witnesses exonerate the gyro only when they make "the gyro is right" at least e^2 (7.4) times
as likely as "the wheels are right" (side_log_likelihood)."""


@jitable
def yaw_follow_step(
    omega: float, u_R: float, u_L: float, v_t: float, v_n: float, g, grip: float = 1.0
) -> float:
    """The body's yaw rate ``omega`` one T_N on, following the wheels through the nominal yaw dynamics
    I_z omega' = b/2 (F_R - F_L) + the shoes' moment, each tyre's F_x from the believed curve at the
    wheel's circumferential speed ``u`` against its contact point's v_t +- omega b/2 and v_n: the
    witness, and the excluded gyro's replacement. Linearly implicit in the tyres' slip stiffness dF/du
    (stable for any dF/du >= 0; past the peak 1 + T_N (b/2)^2 (k_R + k_L) / I_z stays above 0.99 on both
    robots): near zero slip the body follows the odometric yaw rate with the lag 2 I_z / (b^2 dF/du) (12
    ms on Tinyphoon at 1.6 m/s), longer as the tyres saturate. ``g``: HealthConstants (or anything with
    their track_width, T_N, yaw_inertia, wheel_normal_load, tyre and shoe fields); ``grip``: the
    identified tyre peak over the nominal, which scales the curve's forces and stiffness."""
    half = 0.5 * g.track_width
    f_R, _, k_R = tyre_force_and_stiffness(v_t + omega * half, v_n, u_R, g.wheel_normal_load, g)
    f_L, _, k_L = tyre_force_and_stiffness(v_t - omega * half, v_n, u_L, g.wheel_normal_load, g)
    f_R, f_L, k_R, k_L = grip * f_R, grip * f_L, grip * k_R, grip * k_L
    _, moment = shoe_drag(v_t, v_n, omega, g, 0.0, half * (f_R - f_L))
    stiffness = g.T_N * half * half * (k_R + k_L) / g.yaw_inertia
    return omega + g.T_N * (moment / g.yaw_inertia) / (1.0 + stiffness)


def yaw_lag_at_floor(g) -> float:
    """The nominal yaw dynamics' lag behind the wheels at the tyre curve's slip-speed floor (s):
    I_z / ((b/2)^2 2 dF/du) with dF/du = mu N C B / slip_speed_floor, the stiffest the tyres get (inf
    without a tyre curve). Below MIN_YAW_LAG_STEPS T_N yaw_follow_step overshoots as the tyres saturate:
    navigation.health_geometry then sets yaw_inertia 0, and the witness and the gyro's replacement are the
    odometric yaw rate."""
    stiffness = g.tyre_friction * g.wheel_normal_load * g.tyre_shape_factor * g.tyre_stiffness_factor
    if not stiffness > 0.0:
        return math.inf
    return g.yaw_inertia / ((0.5 * g.track_width) ** 2 * 2.0 * stiffness / g.slip_speed_floor)


@jitable
def yaw_witness_step(witness: float, v_R: float, v_L: float, v_t: float, v_n: float, g, grip: float):
    """The witness one T_N on: yaw_follow_step from ``witness`` (the odometric yaw rate when it is NaN)
    with the wheels' speeds v_R, v_L (m/s) at the body's v_t, v_n; without the nominal yaw inertia the
    odometric yaw rate itself."""
    omega_o = (v_R - v_L) / g.track_width
    if g.yaw_inertia <= 0.0:
        return omega_o
    if not math.isfinite(witness):
        witness = omega_o
    return yaw_follow_step(witness, v_R, v_L, v_t, v_n, g, grip)


@jitable
def tyre_grip(v_R: float, v_L: float, v_t: float, v_n: float, omega: float, g) -> float:
    """The smaller of the two tyres' slip stiffness dF/dslip over its value at zero slip, from the
    nominal tyre curve at the wheels' circumferential speeds and their contact points' v_t +- omega b/2,
    v_n (1 in the linear range, 0 at the peak, below past it; 1 without a tyre curve)."""
    half = 0.5 * g.track_width
    ratio = 1.0
    for u, v_x in ((v_R, v_t + omega * half), (v_L, v_t - omega * half)):
        v_ref = max(abs(v_x), abs(u), g.slip_speed_floor)
        sigma = math.hypot((u - v_x) / v_ref, v_n / v_ref)
        b_sigma = g.tyre_stiffness_factor * sigma
        ratio = min(ratio, math.cos(g.tyre_shape_factor * math.atan(b_sigma)) / (1.0 + b_sigma * b_sigma))
    return ratio


def yaw_test_threshold(false_alarm_time: float, T_N: float) -> float:
    """The CUSUM threshold h (sigma) of one false alarm per ``false_alarm_time`` seconds of healthy
    samples at T_N (YAW_DRIFT, YAW_CLIP)."""
    return CusumTest.from_run_length(false_alarm_time / T_N, YAW_DRIFT, YAW_CLIP).threshold


@jitable
def count_yaw_rate(g) -> float:
    """One encoder count of one wheel in one T_N as a yaw rate (rad/s): encoder_step r / (b T_N), r the
    wheels' mean radius (Tinyphoon 0.113)."""
    return g.encoder_step * 0.5 * (g.radius_R + g.radius_L) / (g.track_width * g.T_N)


def yaw_constants(c) -> dict:
    """The yaw test's figures of the record ``c`` (HealthConstants): yaw_residual_floor, sigma_g^2 + q^2 / 3
    (yaw_residual_variance); yaw_smoothing, the gain of the witness's PT1, min(1, T_N / yaw_witness_lag)."""
    return {
        "yaw_residual_floor": c.gyro_noise_std**2 + count_yaw_rate(c) ** 2 / 3.0,
        "yaw_smoothing": min(1.0, c.T_N / c.yaw_witness_lag),
    }


@jitable
def yaw_residual_variance(witness: float, witness_rate: float, c) -> float:
    """The predicted variance S of the residual (gyro - b_g) - witness (rad^2/s^2): sigma_g^2 + q^2 / 3 +
    (yaw_slip_fraction witness)^2 + (yaw_witness_lag witness')^2, the gyro's noise, one encoder count per
    sample of each wheel as a yaw rate (q: count_yaw_rate, the error uniform within a count), the
    differential slip the nominal tyre curve leaves unexplained, and the witness's timing against the gyro
    (the body's unmodelled lag, the streams' relative latency) times its rate of change ``witness_rate``
    (rad/s^2, from its PT1 over yaw_witness_lag). ``c``: HealthConstants (or anything with their
    yaw_slip_fraction, yaw_witness_lag and yaw_residual_floor, yaw_constants)."""
    return (
        c.yaw_residual_floor + (c.yaw_slip_fraction * witness) ** 2 + (c.yaw_witness_lag * witness_rate) ** 2
    )


YAW_TEST_LAYOUT = (
    ("z_variance", 1),
    ("cusum", CUSUM_SIZE),
    ("lateral_gyro", 1),
    ("lateral_wheels", 1),
    ("turned", 1),
)
"""The yaw test's state (gyro_yaw_test), in order (name, size): the observed variance of the normalised
innovation, the CUSUM's sums (CusumState's order), the averages of a_n - v_t omega with the gyro's and
the wheels' omega (m/s^2, NaN: no lateral witness; lateral_update), the heading the wheels' witness
turned while the test judged since its sums last restarted (rad; yaw_test_verdict)."""
_YAW_TEST = layout_slices(YAW_TEST_LAYOUT)
Z_VARIANCE, CUSUM = _YAW_TEST["z_variance"], _YAW_TEST["cusum"]
LATERAL_GYRO, LATERAL_WHEELS = _YAW_TEST["lateral_gyro"], _YAW_TEST["lateral_wheels"]
TURNED = _YAW_TEST["turned"]
YAW_TEST_SIZE = layout_size(YAW_TEST_LAYOUT)
YAW_GATE = 4.0
"""|z| beyond this (in units of the observed spread) does not feed the observed variance (sigma)."""
YAW_NOISE_SAMPLES = 1000.0
"""The observed variance of z averages over this many samples (2 s at T_N)."""


def yaw_test_initial_state() -> list:
    """z's observed variance 1, the sums at zero, no lateral averages, no heading judged."""
    return [1.0] + [0.0] * CUSUM_SIZE + [math.nan, math.nan, 0.0]


@jitable
def lateral_update(state, a_n: float, v_t: float, gyro: float, witness: float, c) -> None:
    """The lateral witness's averages in ``state`` (YAW_TEST_LAYOUT's values, in place): a_n - v_t omega
    with the gyro's omega (``gyro``, less b_g) and with the wheels' (``witness``), rad/s, averaged over
    consistency_samples like the pair's omega^2; ``a_n`` the accelerometers' lateral reading at the pair's
    centre (m/s^2, NaN: none this sample, which restarts both), ``v_t`` the body's speed (m/s)."""
    if not math.isfinite(a_n + v_t + gyro + witness):
        state[LATERAL_GYRO], state[LATERAL_WHEELS] = math.nan, math.nan
        return
    d_gyro, d_wheels = a_n - v_t * gyro, a_n - v_t * witness
    if not math.isfinite(state[LATERAL_GYRO] + state[LATERAL_WHEELS]):
        state[LATERAL_GYRO], state[LATERAL_WHEELS] = d_gyro, d_wheels
        return
    state[LATERAL_GYRO] += (d_gyro - state[LATERAL_GYRO]) / c.consistency_samples
    state[LATERAL_WHEELS] += (d_wheels - state[LATERAL_WHEELS]) / c.consistency_samples


@jitable
def averaged_reading_variance(speed: float, c) -> float:
    """The variance of one accelerometer axis's reading averaged over consistency_samples like the pair's
    omega^2 (an exponential average: / (2 n - 1)), its white noise and its commotion at ``speed`` (m/s;
    the commotion's correlation from one sample to the next, pair_offset_phi, counted: (1 + phi) /
    (1 - phi)), in m^2/s^4."""
    phi = c.pair_offset_phi  # accelerometer_pair.pair_constants
    commotion = (c.accel_vibration_per_speed * speed) ** 2 * (1.0 + phi) / (1.0 - phi)
    return (c.accel_noise_std**2 + commotion) / (2.0 * c.consistency_samples - 1.0)


@jitable
def lateral_variance(speed: float, lateral_acceleration: float, c) -> float:
    """The variance of a lateral average (lateral_update) under the right hypothesis (m^2/s^4): the mean
    of the two accelerometers' averaged readings (averaged_reading_variance / 2), their initial biases'
    mean and the side slip's v_n' as LATERAL_SLIP_FRACTION of ``lateral_acceleration`` v_t omega
    (m/s^2)."""
    slip = LATERAL_SLIP_FRACTION * lateral_acceleration
    return 0.5 * averaged_reading_variance(speed, c) + 0.5 * c.accel_initial_bias_std**2 + slip * slip


@jitable
def pair_squared_variance(speed: float, c, offset_variance: float) -> float:
    """The variance of the pair's averaged omega^2 = -(x d_t + y d_n) / (2 (x^2 + y^2)) (rad^4/s^4): each
    axis's difference of two averaged readings (2 averaged_reading_variance), through the lever, and
    ``offset_variance``, what the pair's offset leaves in it."""
    x, y = c.accelerometer_position
    return averaged_reading_variance(speed, c) / (2.0 * (x * x + y * y)) + offset_variance


@jitable
def side_log_likelihood(
    state, gyro: float, witness: float, pair_squared: float, speed: float, c, pair_variance: float = 0.0
) -> float:
    """log p(third witnesses | the gyro is right) - log p(... | the wheels are right), summed over the
    lateral witness (its averages in ``state``, lateral_variance) and the pair's averaged omega^2
    (``pair_squared``, rad^2/s^2, NaN: none; pair_squared_variance with ``pair_variance``, the variance
    its offset leaves in it) against omega^2 under each hypothesis; NaN when neither witnesses. ``gyro``
    (less b_g) and ``witness`` in rad/s, ``speed`` |v_o| (m/s)."""
    total, witnessed = 0.0, False
    d_gyro, d_wheels = state[LATERAL_GYRO], state[LATERAL_WHEELS]
    if math.isfinite(d_gyro + d_wheels):
        variance = lateral_variance(speed, speed * max(abs(gyro), abs(witness)), c)
        total += (d_wheels * d_wheels - d_gyro * d_gyro) / (2.0 * variance)
        witnessed = True
    if math.isfinite(pair_squared):
        variance = pair_squared_variance(speed, c, pair_variance)
        d_gyro, d_wheels = pair_squared - gyro * gyro, pair_squared - witness * witness
        total += (d_wheels * d_wheels - d_gyro * d_gyro) / (2.0 * variance)
        witnessed = True
    return total if witnessed else math.nan


@jitable
def gyro_yaw_test(
    state,
    gyro: float,
    witness: float,
    witness_rate: float,
    pair_squared: float,
    speed: float,
    c,
    pair_variance: float = 0.0,
) -> bool:
    """One sample of the yaw test (module docstring, 2. and 3.): ``state`` YAW_TEST_LAYOUT's values
    (updated in place), ``gyro`` the gyro less b_g and ``witness`` the wheels' yaw rate (rad/s) with its
    smoothed rate of change ``witness_rate`` (rad/s^2), ``pair_squared`` the pair's averaged omega^2 less
    its offset's share (rad^2/s^2, NaN: no pair to witness) and ``pair_variance`` the variance that
    share leaves (rad^4/s^4), ``speed`` |v_o| (m/s), ``c`` HealthConstants (yaw_threshold).
    Returns True when the gyro is to be excluded; an alarm restarts the sums either way."""
    residual = gyro - witness
    z = residual / math.sqrt(yaw_residual_variance(witness, witness_rate, c))
    # test, normalised by the larger of 1 and the variance the healthy samples show (Mehra)
    spread = math.sqrt(max(1.0, state[Z_VARIANCE]))
    alarm = cusum_update(state[CUSUM], z / spread, YAW_DRIFT, c.yaw_threshold, YAW_CLIP)
    if alarm == 0 and abs(z) <= YAW_GATE * spread:
        state[Z_VARIANCE] += (z * z - state[Z_VARIANCE]) / YAW_NOISE_SAMPLES
    if alarm == 0:
        return False
    yaw_test_restart(state)
    side = side_log_likelihood(state, gyro, witness, pair_squared, speed, c, pair_variance)
    if not math.isfinite(side):  # one witness against the other: no isolation
        return False
    return not side > SIDE_LOG_LIKELIHOOD


@jitable
def yaw_test_verdict(state, witness: float, T_N: float, heading: float) -> float:
    """After a sample the test judged without an alarm (``state``: YAW_TEST_LAYOUT's values, in place):
    the witness's ``witness`` yaw rate (rad/s) over T_N adds to the heading judged; 1.0 (the gyro
    confirmed) when the sums hold no evidence against the gyro (both at zero) over a judged turn of at
    least ``heading`` (rad: a turn's first samples say little of a scale error), else 0.0."""
    state[TURNED] += abs(witness) * T_N
    sums = state[CUSUM]
    return 1.0 if sums[0] == 0.0 and sums[1] == 0.0 and state[TURNED] >= heading else 0.0


@jitable
def yaw_test_restart(state) -> None:
    """The yaw test's CUSUM sums at zero and no heading judged (``state``: YAW_TEST_LAYOUT's values,
    element by element)."""
    sums = state[CUSUM]
    for i in range(len(sums)):
        sums[i] = 0.0
    state[TURNED] = 0.0
