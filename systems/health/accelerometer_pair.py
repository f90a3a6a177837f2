"""The two accelerometers against each other and the kinematics: S(3)'s sensors at +-(x, y) differ by
2 (-omega' y - omega^2 x, omega' x - omega^2 y), the rotational terms, plus the two biases' difference.

``inconsistent``: an axis's disagreement beyond the rotational terms (omega' from the body's yaw rate)
and the pair's learned offset (pair_offset_update), in a moving average over consistency_samples, exceeds
accel_consistency + accel_consistency_per_speed |v_o|; or, while the gyro is trusted, a second average
over fast_consistency_samples exceeds fast_consistency_factor times that bound plus the noise the
gyro's difference puts into the rotational terms (fast_pair_ratio); or the pair's gain test
(systems/health/pair_gain.py) finds one sensor's scale off. The one blamed (pair_axis_decision) has the
larger sum of its change since the pair began to disagree and its distance, in the same moving
average, from the kinematic reference (d v_o/dt for t, v_o omega for n); with the motor drivers'
currents the t axes' reference is the force balance (force_reference), which does not slip as d v_o/dt
does, and the distance alone decides (a hard braking moves the healthy sensor as much as a bias). The
sensor stays out until the pair's averages fall below half their bounds (a hold of the gain test's
alone: until its evidence is gone and that of a gain within gain_release is in).

An excluded axis reads its partner's plus the rotational difference and the learned offset
(analog.analog_outputs). Without two sensors there is no pair: nothing is judged (pair_present).
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.layout import (
    ANALOG_HOLD,
    PAIR_AVERAGE,
    PAIR_DEVIATION,
    PAIR_FAST_AVERAGE,
    PAIR_LEVEL,
    PAIR_OFFSET,
    PAIR_OFFSET_BLOCK_COUNT,
    PAIR_OFFSET_BLOCK_NOISE,
    PAIR_OFFSET_BLOCK_SUM,
    PAIR_OFFSET_VARIANCE,
    PAIR_OMEGA_SQUARED,
    PREVIOUS_ODOMETRIC_SPEED,
)
from slipnav.systems.health.pair_gain import (
    GAIN_HOLD,
    averaged_omega_dot_std,
    pair_gain_ratio,
    pair_gain_reset,
    pair_gain_upper_bound,
)
from slipnav.systems.health.parameters import INCONSISTENT, drive_torque, plausible_currents
from slipnav.systems.residual_test import chi_square_gate
from slipnav.systems.robot.contact import shoe_drag

PAIR_OFFSET_FALSE_ALARM = 1e-4
"""The share of a healthy pair's offset blocks that pair_offset_update's gate refuses to learn from."""
FAST_ROTATION_SIGMAS = 5.0
"""The fast pair test's bound allows this many standard deviations of the noise that the gyro's
sample-to-sample difference (omega') puts into the fast average's rotational terms, 2 omega' y (t) and
2 omega' x (n) (fast_pair_ratio)."""


def pair_constants(c) -> dict:
    """The pair tests' figures of the record ``c`` (HealthConstants), for pair_offset_update:
    pair_offset_drift, pair_offset_white (the disagreement's white noise variance), pair_offset_phi (the
    commotion's correlation from one sample to the next), pair_offset_gate (the chi-square gate of
    PAIR_OFFSET_FALSE_ALARM) and, per axis [t, n], pair_offset_rotation (the variance of a block's summed
    omega' terms on the lever, y for t, x for n); for fast_pair_ratio, per axis, fast_rotation_allowance."""
    omega_dot_std = averaged_omega_dot_std(1.0 / c.fast_consistency_samples, c)
    return {
        "pair_offset_drift": 2.0 * c.accel_drift_density**2 * c.T_N,
        "pair_offset_white": 2.0 * c.accel_noise_std**2,
        "pair_offset_phi": math.exp(-c.T_N / c.accel_vibration_time_constant),
        "pair_offset_gate": chi_square_gate(PAIR_OFFSET_FALSE_ALARM),
        "pair_offset_rotation": tuple(
            2.0 * (2.0 * abs(c.accelerometer_position[1 - axis]) * c.gyro_noise_std / c.T_N) ** 2
            for axis in (0, 1)
        ),
        "fast_rotation_allowance": tuple(
            FAST_ROTATION_SIGMAS * 2.0 * abs(c.accelerometer_position[1 - axis]) * omega_dot_std
            for axis in (0, 1)  # the lever: t, y; n, x
        ),
    }


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
    if not x * x + y * y > 0.0:  # both at one point: no rotational difference to read
        return math.nan
    return -(x * (sample[0] - sample[2]) + y * (sample[1] - sample[3])) / (2.0 * (x * x + y * y))


@jitable
def pair_present(raw, g) -> bool:
    """The robot has two accelerometer sets (HealthGeometry.accelerometer_sets) and they are two sensors,
    not one IMU copied into both sets of a log (the same values on both axes, which say nothing of their
    agreement or of omega^2: two real sensors' noise never repeats)."""
    return g.accelerometer_sets == 2 and not (raw[0] == raw[2] and raw[1] == raw[3])


@jitable
def pair_omega_squared_update(s, raw, p, g) -> float:
    """This sample's omega^2 from the pair (rad^2/s^2; NaN unless the robot has two sets and all four
    readings are finite), averaged into the state over consistency_samples."""
    finite = g.accelerometer_sets == 2 and (
        math.isfinite(raw[0]) and math.isfinite(raw[1]) and math.isfinite(raw[2]) and math.isfinite(raw[3])
    )
    squared = pair_omega_squared(raw, g.accelerometer_position) if finite else math.nan
    if math.isfinite(squared):
        s[PAIR_OMEGA_SQUARED] += (squared - s[PAIR_OMEGA_SQUARED]) / p.consistency_samples
    return squared


@jitable
def pair_rotational_terms(omega: float, previous_omega: float, g) -> tuple:
    """The pair's rotational difference per axis (t, n) at the body's yaw rate ``omega`` (rad/s), and its
    angular-acceleration terms (-2 omega' y, 2 omega' x) with omega' from the previous sample's
    ``previous_omega`` (0 when NaN): noisy per sample, but their integral is x omega (exact)."""
    x, y = g.accelerometer_position
    omega_dot = (omega - previous_omega) / g.T_N if math.isfinite(previous_omega) else 0.0
    return pair_rotational_difference(omega, (x, y)), (-2.0 * omega_dot * y, 2.0 * omega_dot * x)


@jitable
def force_reference(currents, used, previous_increments, first, v_o: float, yaw_rate: float, g) -> float:
    """The force reference of a_t (m/s^2): what the motors put on the ground (their currents ``currents``
    (A) less the wheels' bearing drag and inertia, from the increments ``used`` and the previous ones,
    rad) and the nominal shoe drag at ``v_o`` and ``yaw_rate``, over the nominal mass. NaN without the
    nominal mass, on an encoder's first reading, or without plausible currents (beyond
    PLAUSIBLE_CURRENT x the driver's limit, or none)."""
    if not (g.mass > 0.0) or first[0] or first[1] or not plausible_currents(currents, g.motor_current_limit):
        return math.nan
    radii = (g.radius_R, g.radius_L)
    force = 0.0
    for w in range(2):
        rate = used[w] / g.T_N
        rate_dot = (used[w] - previous_increments[w]) / (g.T_N * g.T_N)
        torque = drive_torque(currents[w], rate, g) - g.wheel_inertia * rate_dot
        force += torque / radii[w]
    force, _ = shoe_drag(v_o, 0.0, yaw_rate, g, force, 0.0)
    return force / g.mass


@jitable
def pair_offset_update(s, axis: int, disagreement: float, speed: float, other: float, p, g):
    """Learns the pair's offset a_1 - a_2 beyond the rotational terms on ``axis`` (the bias difference):
    a scalar Kalman filter (pair_offset, its variance pair_offset_variance: from 2 accel_initial_bias_std^2,
    plus 2 accel_drift_density^2 T_N every sample, the two biases' random walk) whose measurement is the
    mean ``disagreement`` over a block of consistency_samples contiguous samples. The block's omega' terms
    telescope to its ends (variance pair_offset_rotation / n^2); each sample adds its white noise, the
    commotion at ``speed`` (S(3)'s Gauss-Markov process, counted as (1 + phi)/(1 - phi) samples) and
    gain_cross_coupling of the ``other`` axis's acceleration, over n^2. A block whose innovation is beyond
    pair_offset_gate of its variance is a change of the pair, which the pair's tests judge: not learned."""
    count = s[PAIR_OFFSET_BLOCK_COUNT]
    block_sum = s[PAIR_OFFSET_BLOCK_SUM]
    block_noise = s[PAIR_OFFSET_BLOCK_NOISE]
    phi = p.pair_offset_phi
    commotion = g.accel_vibration_per_speed * speed
    # measurement: the block's sums
    block_sum[axis] += disagreement
    block_noise[axis] += (
        p.pair_offset_white
        + 2.0 * commotion**2 * (1.0 + phi) / (1.0 - phi)
        + (p.gain_cross_coupling * other) ** 2
    )
    count[axis] += 1.0
    n = count[axis]
    if n < p.consistency_samples:
        return
    measurement = block_sum[axis] / n
    noise = (block_noise[axis] + p.pair_offset_rotation[axis]) / (n * n)
    pair_offset_block_reset(s, axis)
    offset = s[PAIR_OFFSET]
    variance = s[PAIR_OFFSET_VARIANCE]
    # update step, behind the gate (the variance's prediction: pair_check, every sample)
    innovation = measurement - offset[axis]
    innovation_variance = variance[axis] + noise
    if not innovation_variance > 0.0:  # a noiseless data sheet and no motion: nothing to weigh
        return
    if innovation * innovation > p.pair_offset_gate * innovation_variance:
        return
    gain = variance[axis] / innovation_variance
    offset[axis] += gain * innovation
    variance[axis] *= 1.0 - gain


@jitable
def pair_offset_block_reset(s, axis: int) -> None:
    """Starts the offset's block of ``axis`` afresh (a sample not learned from breaks its contiguity)."""
    count = s[PAIR_OFFSET_BLOCK_COUNT]
    block_sum = s[PAIR_OFFSET_BLOCK_SUM]
    block_noise = s[PAIR_OFFSET_BLOCK_NOISE]
    count[axis] = 0.0
    block_sum[axis] = 0.0
    block_noise[axis] = 0.0


@jitable
def fast_pair_ratio(fast_average: float, limit: float, axis: int, known: bool, p) -> float:
    """The fast pair test's average over its bound, in units of the slow test's bound ``limit`` (> limit
    flags): the bound is fast_consistency_factor x limit plus fast_rotation_allowance, FAST_ROTATION_SIGMAS
    of averaged_omega_dot_std (gain 1 / fast_consistency_samples) on the lever 2 y for t, 2 x for n. 0
    while the test is off or the gyro is not trusted (the odometry's omega' is a count's step)."""
    if not known or math.isinf(p.fast_consistency_factor):
        return 0.0
    bound = p.fast_consistency_factor * limit + p.fast_rotation_allowance[axis]  # pair_constants
    return abs(fast_average) / bound * limit


@jitable
def pair_check(s, raw, codes, rot, rot_dot, omega, a_force, v_o, moving, fast_known, p, g) -> None:
    """The pair's tests on both axes; writes codes[0:4]. ``rot``, ``rot_dot``: pair_rotational_terms;
    ``omega``: the body's yaw rate (rad/s); ``a_force``: force_reference (NaN: none); ``v_o``: the
    odometric speed (m/s); ``moving``: the wheels turned; ``fast_known``: the gyro is trusted on this and
    the previous sample (its omega' is known)."""
    deviation = s[PAIR_DEVIATION]
    level = s[PAIR_LEVEL]
    limit = p.accel_consistency + p.accel_consistency_per_speed * abs(v_o)
    tangential = (v_o - s[PREVIOUS_ODOMETRIC_SPEED]) / g.T_N if math.isnan(a_force) else a_force
    kinematic = (tangential, v_o * omega)
    offset_variance = s[PAIR_OFFSET_VARIANCE]
    for axis in (0, 1):  # the pair's offset drifts with the two biases (pair_offset_update)
        offset_variance[axis] += p.pair_offset_drift
    if not all_in(codes[0:4], (0, INCONSISTENT)):
        # an axis out of the pair for its own fault: the gain test's window is stale when it returns
        pair_gain_reset(s)
        return
    if not pair_present(raw, g):  # fewer than two sensors: no pair to judge
        return
    for c in range(4):
        deviation[c] += (raw[c] - kinematic[c % 2] - deviation[c]) / p.consistency_samples
        if not math.isfinite(level[c]):
            level[c] = raw[c]
    for axis in (0, 1):
        fast, gain = pair_axis_evidence(
            s, axis, raw, codes, rot, rot_dot, limit, abs(v_o), moving, fast_known, p, g
        )
        force_known = axis == 0 and not math.isnan(a_force)
        pair_axis_decision(s, axis, raw, codes, limit, fast, gain, force_known, fast_known, p)


@jitable
def pair_axis_evidence(s, axis, raw, codes, rot, rot_dot, limit, speed, moving, fast_known, p, g) -> tuple:
    """One axis's averages of the offset-free disagreement, its offset update and its gain test:
    returns (fast_pair_ratio, pair_gain_ratio)."""
    average = s[PAIR_AVERAGE]
    fast_average = s[PAIR_FAST_AVERAGE]
    offset = s[PAIR_OFFSET]
    disagreement = raw[axis] - raw[axis + 2] - rot[axis] - rot_dot[axis]
    offset_free = disagreement - offset[axis]  # less the two biases' learned difference
    average[axis] += (offset_free - average[axis]) / p.consistency_samples
    if fast_known:
        fast_average[axis] += (offset_free - fast_average[axis]) / p.fast_consistency_samples
    else:  # the replacement's omega' is not averaged in: restart from the slow average
        fast_average[axis] = average[axis]
    fast = fast_pair_ratio(fast_average[axis], limit, axis, fast_known, p)  # 0: off, or no gyro
    mean = 0.5 * (raw[axis] + raw[axis + 2])
    other = 0.5 * (raw[1 - axis] + raw[3 - axis])
    # learned with the gyro's omega' on this sample (fast_known) and both axes healthy
    if fast_known and codes[axis] == 0 and codes[axis + 2] == 0:
        pair_offset_update(s, axis, disagreement, speed, other, p, g)
    else:
        pair_offset_block_reset(s, axis)
    rotation = rot[axis] + rot_dot[axis]
    gain = pair_gain_ratio(s, axis, offset_free, mean, rotation, other, speed, moving, fast_known, p, g)
    return fast, gain


@jitable
def pair_axis_decision(s, axis, raw, codes, limit, fast, gain, force_known, fast_known, p) -> None:
    """One axis's flag, blame and release (module docstring): each sensor's level follows it while the
    pair agrees; a flag blames by the change from the level plus the distance from the kinematics (each
    alone errs: the true signal moves meanwhile, and the wheels slip), by the distance alone with the force
    reference (``force_known``) or when only the gain test flags (a scale fault grows with the signal)."""
    average = s[PAIR_AVERAGE]
    deviation = s[PAIR_DEVIATION]
    level = s[PAIR_LEVEL]
    hold = s[ANALOG_HOLD]
    pair_of = (axis, axis + 2)  # sensor 1's and sensor 2's channel of this axis
    held = hold[axis] != 0.0 or hold[axis + 2] != 0.0
    if abs(average[axis]) < 0.5 * limit and not held:  # each sensor's level while the pair agrees
        for c in pair_of:
            level[c] += (raw[c] - level[c]) / p.consistency_samples
    averages_flag = abs(average[axis]) > limit or fast > limit
    if averages_flag:  # the averages' evidence (a bias) takes over a hold of the gain test's
        for c in pair_of:
            hold[c] = 1.0 if hold[c] == GAIN_HOLD else hold[c]
    if (averages_flag or gain > 1.0) and not held:
        distance_only = force_known or not averages_flag
        score = [abs(deviation[c]) for c in pair_of]
        if not distance_only:
            score = [score[i] + abs(raw[pair_of[i]] - level[pair_of[i]]) for i in range(2)]
        bad = pair_of[0] if score[0] > score[1] else pair_of[1]
        hold[bad] = 1.0 if averages_flag else GAIN_HOLD
        codes[bad] = INCONSISTENT
    # a hold by the gain test alone (GAIN_HOLD) is released when its evidence of the fault is gone and
    # that of a gain within gain_release is in; the averages' hold (1) when theirs is gone
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


@jitable
def all_in(values, allowed) -> bool:
    """Every one of ``values`` is one of ``allowed``."""
    for value in values:
        if value not in allowed:
            return False
    return True
