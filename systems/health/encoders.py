"""The encoders against the other wheel and the gyro: [theta_R, theta_L], judged by their raw-to-raw
increments against v_pred = v_other +- b omega, the calibrated prediction v_R - v_L = b (gyro - b_g) - D v_o
(predicted_increment; systems/navigation/yaw_calibration.py).

- ``nonfinite``: NaN or inf.
- ``jump``: an increment implying a wheel speed beyond max_wheel_speed, or a change of the wheel speed
  beyond max_wheel_acceleration max(T_N, encoder_hold_time) plus two counts against the last used
  increment (a log that holds its angles between readings changes its speed at once by what the wheel
  gained over the interval).
- ``stuck``: a count standing still for stuck_samples beyond the stream's encoder_hold_time while v_pred
  exceeds stuck_min_speed + stuck_speed_fraction |v_other| on average (a wheel held by hand, about which
  the robot pivots on rolling tyres, is not flagged); a sample on which the healthy tangential
  accelerometers' mean brakes against the wheel's motion harder than stuck_braking_deceleration restarts
  the count (a hard braking locks a wheel honestly). The travel missed before the detection is added then.
- ``inconsistent``: the encoder reads its wheel turning against the ground beneath it
  (systems/health/ground_speed.py).
- ``recovering``: excluded until a re-admission block agrees (readmission_block); without a prediction,
  one increment agreeing with the previous one suffices. No exclusion ends on a timer.

An excluded encoder advances by v_pred T_N / r, else by its last increment (encoder_outputs); the first
increment after an exclusion (it spans the gap) is never used.
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.analog import body_acceleration, hold_samples, readmission_sample
from slipnav.systems.health.layout import (
    BLOCK_DIFFERENCE,
    BLOCK_SAMPLES,
    BLOCK_TRAVEL,
    ENCODER_BLOCK_L,
    ENCODER_BLOCK_MOVED,
    ENCODER_BLOCK_R,
    ENCODER_CODE,
    ENCODER_INCREMENT,
    ENCODER_LAST_RAW,
    ENCODER_LOST,
    ENCODER_OUTPUT_OFFSET,
    ENCODER_RAW_INCREMENT,
    ENCODER_STILL,
    ENCODER_STILL_PREDICTED,
    ENCODER_STILL_PREDICTED_ABS,
    ENCODER_SUSPECT,
    TRAVEL_RESTORED,
)
from slipnav.systems.health.parameters import FIRST_ENCODER, JUMP, NONFINITE, RECOVERING, STUCK

READMISSION_TRAVEL_COUNTS = 10.0
"""The counts an encoder excluded for a disagreement (suspect) must itself count in its re-admission block
before the block is judged (five times its two-count allowance): at rest a sign-flipped or doubled encoder
agrees with any prediction. One excluded for a non-finite reading comes back at rest."""


def encoder_constants(c) -> dict:
    """The encoder tests' figures of the record ``c`` (HealthConstants): encoder_jump_bound, the jump
    test's bound on the change of the increment per wheel [R, L] (rad); encoder_stuck_samples, the still
    samples that make a stuck count (hold_samples)."""
    count_speed = 2.0 * c.encoder_step / c.T_N
    return {
        "encoder_jump_bound": tuple(
            (c.max_wheel_acceleration * max(c.T_N, c.encoder_hold_time) / r + count_speed) * c.T_N
            for r in (c.radius_R, c.radius_L)
        ),
        "encoder_stuck_samples": c.stuck_samples + hold_samples(c.encoder_hold_time, c.T_N),
    }


@jitable
def predicted_increment(w: int, other_increment: float, gyro: float, radius_difference: float, g) -> float:
    """Wheel w's increment (rad) from the other wheel's and the gyro less b_g (rad/s), v_pred in the nominal
    radii, v_o taken as the other wheel's."""
    radii = (g.radius_R, g.radius_L)
    v_other = other_increment * radii[1 - w] / g.T_N
    turn = g.track_width * gyro - radius_difference * v_other
    return (v_other + (1.0 if w == 0 else -1.0) * turn) * g.T_N / radii[w]


@jitable
def previous_encoder_output(s) -> list:
    """The angles the encoders output on the previous sample (rad; NaN: none yet)."""
    last = s[ENCODER_LAST_RAW]
    offset = s[ENCODER_OUTPUT_OFFSET]
    return [last[0] + offset[0], last[1] + offset[1]]


@jitable
def encoder_increments(s, raw, gyro: float, radius_difference: float, gyro_ok: bool, codes, p, g) -> tuple:
    """Judges each encoder's raw increment (nonfinite, jump, recovering); writes codes[5:7]. Returns (the
    accepted increments, NaN where none; True on the encoder's first reading; True where the sample
    extended a re-admission block not judged yet)."""
    last = s[ENCODER_LAST_RAW]
    increment = s[ENCODER_INCREMENT]
    code = s[ENCODER_CODE]
    lost = s[ENCODER_LOST]
    raw_increment = s[ENCODER_RAW_INCREMENT]
    suspect = s[ENCODER_SUSPECT]
    radii = (g.radius_R, g.radius_L)
    inc, first, in_block = [math.nan, math.nan], [False, False], [False, False]
    candidate = [math.nan, math.nan]  # the healthy wheels' raw increments, for re-admission
    for w in range(2):
        x = raw[FIRST_ENCODER + w]
        if code[w] == 0 and lost[w] == 0 and math.isfinite(x) and math.isfinite(last[w]):
            candidate[w] = x - last[w]
    for w in range(2):
        x = raw[FIRST_ENCODER + w]
        if not math.isfinite(x):
            codes[FIRST_ENCODER + w] = NONFINITE
            continue
        if not math.isfinite(last[w]):  # the first reading: the output starts there
            last[w] = x
            s[ENCODER_OUTPUT_OFFSET][w] = 0.0
            first[w] = True
            continue
        d, last[w] = x - last[w], x
        d_prev, raw_increment[w] = raw_increment[w], d
        bound = p.encoder_jump_bound[w]
        if lost[w] > 0:
            codes[FIRST_ENCODER + w] = RECOVERING  # this increment spans the exclusion
        elif abs(d) * radii[w] / g.T_N > g.max_wheel_speed:
            codes[FIRST_ENCODER + w] = JUMP
        elif code[w] in (0, STUCK):
            if abs(d - increment[w]) > bound:
                codes[FIRST_ENCODER + w], suspect[w] = JUMP, 1.0
            else:
                inc[w] = d
        else:  # re-admission: agree with the prediction, else (none) with the last raw increment
            other = candidate[1 - w]
            if math.isfinite(other) and gyro_ok:
                expected = predicted_increment(w, other, gyro, radius_difference, g)
                ok, in_block[w] = readmission_block(s, w, d, expected, bound, p, g)
            else:
                ok = abs(d - d_prev) <= bound
            if ok:
                inc[w], suspect[w] = d, 0.0
            else:
                codes[FIRST_ENCODER + w] = RECOVERING
    return inc, first, in_block


@jitable
def readmission_block(s, w: int, d: float, expected: float, bound: float, p, g) -> tuple:
    """One sample of wheel ``w``'s re-admission block: each increment ``d`` agrees with the ``expected``
    one within the jump ``bound`` (else the wheel is suspect and the block restarts), and over
    encoder_readmission_samples (for a suspect one, once it counted READMISSION_TRAVEL_COUNTS) their summed
    difference stays within two counts plus encoder_readmission_fraction of the predicted travel: the
    counts' quantisation telescopes, a scale error does not. Returns (re-admitted, the block goes on)."""
    suspect = s[ENCODER_SUSPECT]
    if abs(d - expected) > bound:
        suspect[w] = 1.0
        return False, False
    block = s[ENCODER_BLOCK_R] if w == 0 else s[ENCODER_BLOCK_L]  # READMISSION_LAYOUT's values
    block_moved = s[ENCODER_BLOCK_MOVED]
    fraction = p.encoder_readmission_fraction
    allowed = readmission_sample(block, d - expected, expected, 0.0, 2.0 * g.encoder_step, fraction)
    block_moved[w] += abs(d)
    moved = block_moved[w] >= READMISSION_TRAVEL_COUNTS * g.encoder_step
    if block[BLOCK_SAMPLES] >= p.encoder_readmission_samples and (moved or suspect[w] == 0.0):
        ok = abs(block[BLOCK_DIFFERENCE]) <= allowed
        suspect[w] = suspect[w] if ok else 1.0
        return ok, False
    return False, True


@jitable
def encoder_stuck_test(s, raw, inc, predicted, codes, p, g) -> list:
    """The stuck test on the accepted increments ``inc`` and the ``predicted`` ones (rad, NaN: none);
    writes codes[5:7]. Returns the travel each encoder missed before its detection (rad)."""
    still = s[ENCODER_STILL]
    still_predicted = s[ENCODER_STILL_PREDICTED]
    still_predicted_abs = s[ENCODER_STILL_PREDICTED_ABS]
    code = s[ENCODER_CODE]
    suspect = s[ENCODER_SUSPECT]
    radii = (g.radius_R, g.radius_L)
    a_body = body_acceleration(raw, codes, p)  # the healthy tangential accelerometers' (NaN: none)
    missed = [0.0, 0.0]
    for w in range(2):
        braking = math.isfinite(predicted[w]) and a_body * math.copysign(1.0, predicted[w]) < (
            -p.stuck_braking_deceleration
        )
        if inc[w] == 0.0 and code[w] == STUCK:
            codes[FIRST_ENCODER + w] = STUCK  # still stuck
        elif inc[w] == 0.0 and math.isfinite(predicted[w]) and not braking:
            still[w] += 1
            still_predicted[w] += predicted[w]
            still_predicted_abs[w] += abs(predicted[w])
            v_other = abs(inc[1 - w]) * radii[1 - w] / g.T_N
            mean_predicted = still_predicted_abs[w] * radii[w] / (still[w] * g.T_N)
            if (
                still[w] >= p.encoder_stuck_samples
                and mean_predicted > p.stuck_min_speed + p.stuck_speed_fraction * v_other
            ):
                codes[FIRST_ENCODER + w], suspect[w] = STUCK, 1.0
                missed[w] = still_predicted[w] - predicted[w]  # the travel missed before the detection
        else:
            still[w] = still_predicted[w] = still_predicted_abs[w] = 0.0
            if math.isfinite(inc[w]) and code[w] == STUCK:  # the stuck counter resumes with a lump
                codes[FIRST_ENCODER + w], inc[w] = RECOVERING, math.nan
    return missed


@jitable
def encoder_outputs(s, codes, inc, predicted, first, in_block, missed, previous_output, out) -> list:
    """Writes out[5:7]: the reading itself while the encoder is healthy, less its offset from replacements;
    else ``previous_output`` (previous_encoder_output) plus the predicted increment, else the last one, and
    the ``missed`` travel. Returns the increments used (rad)."""
    last = s[ENCODER_LAST_RAW]
    offset = s[ENCODER_OUTPUT_OFFSET]
    increment = s[ENCODER_INCREMENT]
    code = s[ENCODER_CODE]
    lost = s[ENCODER_LOST]
    block_moved = s[ENCODER_BLOCK_MOVED]
    used = [0.0, 0.0]
    for w in range(2):
        c = FIRST_ENCODER + w
        if first[w]:
            used[w] = 0.0
        elif codes[c] == 0 and math.isfinite(inc[w]):
            used[w] = inc[w]
        elif math.isfinite(predicted[w]):
            used[w] = predicted[w]
        else:
            used[w] = increment[w]
        if first[w] or (codes[c] == 0 and used[w] == inc[w]):
            out[c] = last[w] + offset[w]  # the reading itself, less its offset from replacements
        elif math.isfinite(previous_output[w]):
            out[c] = previous_output[w] + used[w] + missed[w]
            offset[w] = out[c] - last[w]
        else:
            out[c] = math.nan
        lost[w] = 1.0 if codes[c] in (NONFINITE, JUMP) else 0.0
        code[w] = codes[c]
        increment[w] = increment[w] if first[w] else used[w]  # the first keeps the initial speed's increment
        if not in_block[w]:  # judged, broken, or no block: the next one starts anew
            block = s[ENCODER_BLOCK_R] if w == 0 else s[ENCODER_BLOCK_L]
            block[BLOCK_SAMPLES] = block[BLOCK_DIFFERENCE] = block[BLOCK_TRAVEL] = block_moved[w] = 0.0
    s[TRAVEL_RESTORED] = 1.0 if missed[0] != 0.0 or missed[1] != 0.0 else 0.0
    return used
