"""The gyro against its witnesses: the wheels (through the nominal yaw dynamics) and the accelerometer
pair (|omega| from S(3)'s centripetal difference).

- ``inconsistent``: the yaw test (systems/health/yaw_witness.py) finds the gyro's yaw rate in a turn
  unconfirmed by the wheels' witness and not supported by the pair's |omega| (gyro_yaw_check).
- The verdict (layout.yaw_verdict): the yaw test confirms the gyro over a judged turn of
  YAW_RELEASE_HEADING or blames it; the yaw calibration keeps its estimate at each confirmation and
  returns there on a blame (systems/navigation/confirmed_estimate.py).
- Re-admission (gyro_readmission): an excluded gyro comes back only when a block of samples agrees with
  its replacement, sample by sample and in sum (a scale error does not telescope); one the yaw test
  holds out needs a block that turned YAW_RELEASE_HEADING and agrees in sum within the test's own
  allowance for the tyres' differential slip (yaw_slip_fraction). No exclusion ends on a timer.
- A new level is a bias to estimate (gyro_bias_step_block): while the gyro is out for a jump, a steady
  residual while driving straight is a bias step, which the calibration adds to b_g; the gyro less the
  new b_g then agrees.
- Replacement (wheels_yaw_rate, body_yaw_rate): the yaw rate the nominal yaw dynamics give the body
  from the wheels' calibrated speeds (yaw_follow_step, from the replacement's last value), the plain
  odometric yaw rate without the nominal robot's figures, else the last value; a saturated gyro's from
  the pair or the wheels; a frozen gyro's from the wheels' yaw rate run through the repeats it was trusted
  for, with the heading they missed paid back (frozen_gyro_shadow).
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.accelerometer_pair import pair_omega_squared, pair_present
from slipnav.systems.health.analog import SATURATION_RELEASED, readmission_sample
from slipnav.systems.health.layout import (
    ANALOG_EXCLUDED,
    ANALOG_HOLD,
    ANALOG_REFERENCE,
    ANALOG_REPEATS,
    ANALOG_SATURATED,
    BIAS_BLOCK_COUNT,
    BIAS_BLOCK_SQUARES,
    BIAS_BLOCK_SUM,
    BIAS_BLOCK_TURN,
    BIAS_STEP,
    BLOCK_DIFFERENCE,
    BLOCK_SAMPLES,
    BLOCK_TRAVEL,
    FROZEN_GYRO_OWED,
    FROZEN_GYRO_SHADOW,
    GYRO_BLOCK,
    PAIR_OFFSET,
    PAIR_OFFSET_VARIANCE,
    PAIR_OMEGA_SQUARED,
    PAYBACK_LEFT,
    PAYBACK_RATE,
    YAW_TEST,
    YAW_VERDICT,
    YAW_WITNESS,
    YAW_WITNESS_SMOOTH,
)
from slipnav.systems.health.parameters import GYRO, INCONSISTENT, JUMP, RECOVERING, SATURATED, STUCK
from slipnav.systems.health.yaw_witness import (
    GRIP_STIFFNESS_RATIO,
    count_yaw_rate,
    gyro_yaw_test,
    lateral_update,
    tyre_grip,
    yaw_follow_step,
    yaw_test_restart,
    yaw_test_verdict,
    yaw_witness_step,
)

PAIR_SPIN_MARGIN = 1.5
"""A gyro railed at its full scale while the odometry says below it reads the pair's yaw rate only when
the pair says more than the full scale and this many times the odometric yaw rate (a spin the wheels do
not see: a lifted wheel's; body_yaw_rate): on Tinyphoon's short lever the pair's averaged yaw rate reads
up to a third above the body's."""
YAW_RELEASE_HEADING = 0.05
"""A gyro the yaw test holds out is re-admitted only by a block whose replacement turned this much (rad,
3 deg): driving straight says nothing of a scale error. The test confirms the gyro (layout.yaw_verdict)
only over a judged turn of this much (yaw_witness.yaw_test_verdict)."""
BIAS_STEP_SIGMAS = 4.0
"""An excluded gyro's residual may spread this many of its noise sigmas (plus the wheels' quantisation)
over a block that measures a new bias (gyro_bias_step_block): a gyro that reads noise, or a turn the
wheels do not see, is no bias."""


@jitable
def gyro_readmission(s, raw, bias: float, codes, p, g) -> None:
    """The excluded gyro's re-admission block, then its bias-step block: codes[4] is RECOVERING
    (INCONSISTENT while the yaw test holds it) until gyro_readmission_samples in a row within the jump
    bound of the replacement sum their difference from it (a heading) within 3 noise sigmas sqrt(n), two
    counts of each wheel and gyro_readmission_fraction of the replacement's summed magnitude
    (yaw_slip_fraction for a gyro the yaw test holds: that test's allowance), then 0.
    An unwitnessed gyro off its rail (analog.witnessed, ANALOG_SATURATED) is back without a block."""
    reference = s[ANALOG_REFERENCE]
    hold = s[ANALOG_HOLD]
    block = s[GYRO_BLOCK]
    held = hold[GYRO] > 0.0
    judged = codes[GYRO] == 0 or (held and codes[GYRO] == INCONSISTENT)
    judged = judged and s[ANALOG_SATURATED][GYRO] != SATURATION_RELEASED  # off its rail, unwitnessed
    goes_on = False  # the block goes on to the next sample
    if judged and s[ANALOG_EXCLUDED][GYRO] > 0.0 and math.isfinite(reference[GYRO]):
        codes[GYRO] = INCONSISTENT if held else RECOVERING  # until a block agrees
        counts = 4.0 * count_yaw_rate(g)  # two counts of each wheel
        noise = 3.0 * g.gyro_noise_std
        fraction = p.yaw_slip_fraction if held else p.gyro_readmission_fraction  # held: the yaw test's share
        residual = raw[GYRO] - bias - reference[GYRO]
        allowed = readmission_sample(block, residual, reference[GYRO], noise, counts, fraction)
        informative = not held or block[BLOCK_TRAVEL] * g.T_N >= YAW_RELEASE_HEADING
        goes_on = block[BLOCK_SAMPLES] < p.gyro_readmission_samples or not informative
        if not goes_on and not abs(block[BLOCK_DIFFERENCE]) > allowed:
            codes[GYRO], hold[GYRO] = 0, 0.0
    if not goes_on:  # judged, or no block: the next one starts anew
        block[BLOCK_SAMPLES] = block[BLOCK_DIFFERENCE] = block[BLOCK_TRAVEL] = 0.0
    gyro_bias_step_block(s, codes[GYRO], raw[GYRO] - bias - reference[GYRO], reference[GYRO], p, g)


@jitable
def gyro_bias_step_block(s, code: int, residual: float, replacement: float, p, g) -> None:
    """While the gyro is out for a jump (``code`` JUMP, RECOVERING), its ``residual`` against the
    ``replacement`` (raw - b_g - replacement, rad/s) is summed over blocks of bias_step_samples. A block
    whose replacement stays within bias_step_yaw_rate and whose residual spreads within BIAS_STEP_SIGMAS
    of the gyro's noise plus one count of each wheel (as a yaw rate) measures a new bias: its mean, unless
    within BIAS_STEP_SIGMAS of its standard error, is handed to the calibration (layout.gyro_bias_step)."""
    s[BIAS_STEP] = 0.0
    if code != JUMP and code != RECOVERING or not math.isfinite(residual):
        s[BIAS_BLOCK_COUNT] = s[BIAS_BLOCK_SUM] = s[BIAS_BLOCK_SQUARES] = s[BIAS_BLOCK_TURN] = 0.0
        return
    s[BIAS_BLOCK_COUNT] += 1.0
    s[BIAS_BLOCK_SUM] += residual
    s[BIAS_BLOCK_SQUARES] += residual * residual
    s[BIAS_BLOCK_TURN] = max(s[BIAS_BLOCK_TURN], abs(replacement))
    n = s[BIAS_BLOCK_COUNT]
    if n < p.bias_step_samples:
        return
    mean = s[BIAS_BLOCK_SUM] / n
    spread = math.sqrt(max(s[BIAS_BLOCK_SQUARES] / n - mean * mean, 0.0))
    counts = 2.0 * count_yaw_rate(g)  # one count of each wheel
    measured = abs(mean) > BIAS_STEP_SIGMAS * max(spread, g.gyro_noise_std) / math.sqrt(n)
    steady = spread <= BIAS_STEP_SIGMAS * g.gyro_noise_std + counts
    if s[BIAS_BLOCK_TURN] <= p.bias_step_yaw_rate and steady and measured:
        s[BIAS_STEP] = mean
    s[BIAS_BLOCK_COUNT] = s[BIAS_BLOCK_SUM] = s[BIAS_BLOCK_SQUARES] = s[BIAS_BLOCK_TURN] = 0.0


@jitable
def frozen_gyro_shadow(s, raw, bias: float, codes, wheels, encoders_ok: bool, model: bool, p, g) -> None:
    """A frozen gyro is trusted for stuck_samples - 2 repeats: the wheels' yaw rate runs through them from
    the last reading that changed, and the heading the repeats missed against it is owed. When the stuck
    test flags the gyro, its reference starts from there and the heading is paid back over stuck_samples
    samples (analog.analog_outputs). Anchored afresh after any exclusion. ``wheels``: check.wheel_motion's;
    ``encoders_ok``: both encoders healthy; ``model``: the nominal yaw dynamics serve (else the odometric
    yaw rate)."""
    shadow = s[FROZEN_GYRO_SHADOW]
    if codes[GYRO] == 0 and s[ANALOG_REPEATS][GYRO] == 0:
        s[FROZEN_GYRO_SHADOW], s[FROZEN_GYRO_OWED] = raw[GYRO] - bias, 0.0
    elif codes[GYRO] == 0 and math.isfinite(shadow) and encoders_ok:
        v_R, v_L, v_t, v_n, omega_o, grip = wheels
        s[FROZEN_GYRO_SHADOW] = yaw_follow_step(shadow, v_R, v_L, v_t, v_n, g, grip) if model else omega_o
        s[FROZEN_GYRO_OWED] += s[FROZEN_GYRO_SHADOW] - (raw[GYRO] - bias)
    stuck_now = codes[GYRO] == STUCK and s[ANALOG_EXCLUDED][GYRO] == 0.0
    if stuck_now and math.isfinite(shadow) and encoders_ok:
        s[ANALOG_REFERENCE][GYRO] = shadow
        s[PAYBACK_LEFT] = float(p.stuck_samples)
        s[PAYBACK_RATE] = s[FROZEN_GYRO_OWED] / p.stuck_samples
    if codes[GYRO] != 0:
        s[FROZEN_GYRO_SHADOW], s[FROZEN_GYRO_OWED] = math.nan, 0.0


@jitable
def gyro_yaw_check(s, raw, bias: float, codes, wheels, encoders_ok: bool, v_o: float, p, g) -> bool:
    """The wheels' witness of the gyro and the yaw test (systems/health/yaw_witness.py), once per
    sample: True when the test holds the gyro out (hold, codes[4] INCONSISTENT; layout.yaw_verdict -1;
    yaw_witness.yaw_test_verdict's 1 when it confirmed the gyro). ``wheels``:
    check.wheel_motion's; ``v_o``: the odometric speed (m/s). The witness and the tyres' grip are taken
    without side slip: the navigation's v_n integrates a_n - v_t omega with the gyro under test, and a
    gyro that reads 30 % too much in a 1 m/s turn at 0.8 rad/s builds 0.1 m/s of it in 0.4 s, past the
    tyres' peak, which would pause its own test."""
    v_R, v_L, v_t, _, omega_o, grip = wheels
    v_n = 0.0  # along the rolling direction: the navigation's v_n integrates the gyro under test
    witness = s[YAW_WITNESS] if math.isfinite(s[YAW_WITNESS]) else omega_o
    gripping = encoders_ok and tyre_grip(v_R, v_L, v_t, v_n, witness, g) >= GRIP_STIFFNESS_RATIO
    if gripping and not math.isfinite(s[YAW_WITNESS]) and codes[GYRO] == 0:
        witness = raw[GYRO] - bias
    s[YAW_WITNESS] = yaw_witness_step(witness, v_R, v_L, v_t, v_n, g, grip) if gripping else math.nan
    smooth = s[YAW_WITNESS_SMOOTH] if math.isfinite(s[YAW_WITNESS_SMOOTH]) else s[YAW_WITNESS]
    s[YAW_WITNESS_SMOOTH] = smooth + (s[YAW_WITNESS] - smooth) * p.yaw_smoothing  # yaw_constants
    witness_rate = (s[YAW_WITNESS_SMOOTH] - smooth) / g.T_N if math.isfinite(s[YAW_WITNESS_SMOOTH]) else 0.0
    test = s[YAW_TEST]
    gyro = raw[GYRO] - bias
    lateral_update(test, lateral_reading(s, raw, codes, g), v_t, gyro, s[YAW_WITNESS], p)
    s[YAW_VERDICT] = 0.0
    if codes[GYRO] == 0 and gripping and abs(s[YAW_WITNESS]) > p.bias_step_yaw_rate:  # a turn: the scale's
        pair, pair_variance = pair_yaw_witness(s, raw, g)
        if gyro_yaw_test(test, gyro, s[YAW_WITNESS], witness_rate, pair, abs(v_o), p, pair_variance):
            s[ANALOG_HOLD][GYRO], codes[GYRO], s[YAW_VERDICT] = 1.0, INCONSISTENT, -1.0
            return True
        s[YAW_VERDICT] = yaw_test_verdict(test, s[YAW_WITNESS], g.T_N, YAW_RELEASE_HEADING)
    else:
        yaw_test_restart(test)
    return False


@jitable
def pair_yaw_witness(s, raw, g) -> tuple:
    """The pair's averaged omega^2 less the share of its learned offset a_1 - a_2 (pair_offset), and the
    variance that share leaves (rad^2/s^2, rad^4/s^4; through omega^2 = -(x d_t + y d_n) / (2 (x^2 +
    y^2)), accelerometer_pair.pair_omega_squared); (NaN, 0) when the pair does not witness
    (pair_witnesses)."""
    if not pair_witnesses(raw, g):
        return math.nan, 0.0
    x, y = g.accelerometer_position
    scale = 2.0 * (x * x + y * y)
    offset = s[PAIR_OFFSET]
    variance = s[PAIR_OFFSET_VARIANCE]
    share = pair_omega_squared((offset[0], offset[1], 0.0, 0.0), (x, y))  # the offset as a difference
    return s[PAIR_OMEGA_SQUARED] - share, (x * x * variance[0] + y * y * variance[1]) / (scale * scale)


@jitable
def lateral_reading(s, raw, codes, g) -> float:
    """The lateral acceleration at the pair's centre (m/s^2) for the yaw test's lateral witness
    (yaw_witness.lateral_update): the mean of a_n1 and a_n2 when the robot has two sensors (pair_present)
    and both are finite, healthy and not excluded; a_n1 alone when one set sits at the body's origin;
    NaN otherwise."""
    excluded = s[ANALOG_EXCLUDED]
    n1_ok = codes[1] == 0 and excluded[1] == 0.0 and math.isfinite(raw[1])
    if g.accelerometer_sets == 2:
        n2_ok = codes[3] == 0 and excluded[3] == 0.0 and math.isfinite(raw[3])
        return 0.5 * (raw[1] + raw[3]) if n1_ok and n2_ok and pair_present(raw, g) else math.nan
    x, y = g.accelerometer_position
    if g.accelerometer_sets == 1 and n1_ok and x == 0.0 and y == 0.0:
        return raw[1]
    return math.nan


@jitable
def pair_witnesses(raw, g) -> bool:
    """The accelerometer pair is a third witness of the yaw rate on this sample: its sensors sit apart
    (accelerometer_position not (0, 0)), all four readings are finite, and the robot has two sensors
    (pair_present: two sets, not one IMU copied into both, which says nothing of omega^2)."""
    x, y = g.accelerometer_position
    if not x * x + y * y > 0.0:
        return False
    for c in range(4):
        if not math.isfinite(raw[c]):
            return False
    return pair_present(raw, g)


@jitable
def wheels_yaw_rate(s, gyro_ok: bool, wheels, model: bool, g) -> float:
    """The wheels' yaw rate for an excluded gyro: the body's, through the nominal yaw dynamics from the
    replacement's last value (``model``: both encoders healthy and the nominal yaw inertia known), else
    the odometric one (rad/s)."""
    v_R, v_L, v_t, v_n, omega_o, grip = wheels
    reference = s[ANALOG_REFERENCE][GYRO]
    if not gyro_ok and model and math.isfinite(reference):
        return yaw_follow_step(reference, v_R, v_L, v_t, v_n, g, grip)
    return omega_o


@jitable
def body_yaw_rate(
    s, raw, bias: float, codes, gyro_ok: bool, encoders_ok: bool, omega_wheels, omega_o, pair_squared, p
):
    """The body's yaw rate this sample (rad/s, without b_g): the gyro's, else the wheels'
    (``omega_wheels``). A saturated gyro reads this sample's pair yaw rate, at least its full scale, with
    the gyro's sign; with both encoders healthy, the wheels' when the odometry says below the full scale
    and the averaged pair not more than both it and PAIR_SPIN_MARGIN times the odometric ``omega_o`` (the
    gyro reads beyond the robot). One clipped at a rail below the range reads the wheels' yaw rate,
    without both encoders the pair's, at least the rail. ``pair_squared``: this sample's omega^2 from the
    pair (NaN: none)."""
    omega = raw[GYRO] - bias if gyro_ok else omega_wheels
    if codes[GYRO] != SATURATED:
        return omega
    full_scale = p.saturation_fraction * p.gyro_range
    railed = abs(raw[GYRO]) >= full_scale  # else clipped below the data sheet's range (a plateau)
    pair = math.sqrt(max(s[PAIR_OMEGA_SQUARED], 0.0))
    beyond_wheels = pair > max(full_scale, PAIR_SPIN_MARGIN * abs(omega_o))  # a spin they miss
    if encoders_ok and (not railed or (abs(omega_o) < full_scale and not beyond_wheels)):
        return omega_wheels  # the gyro reads beyond what the robot does (railed, or its scale)
    # this sample's pair (the averaged one lags a spin's onset)
    this_sample = math.sqrt(max(pair_squared, 0.0)) if math.isfinite(pair_squared) else 0.0
    return math.copysign(max(full_scale if railed else abs(raw[GYRO]), this_sample), raw[GYRO])
