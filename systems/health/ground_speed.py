"""The ground beneath each wheel, and the encoder that reads its wheel turning against it.

A wheel whose tyre runs backward over the ground at slip ratio below -1 takes the tyre's full sliding
friction against the body's motion on its side: the body brakes and yaws towards it. A wheel can do
that (a reverse command while the body still slides on), a sign-flipped encoder only seems to: it reads
its wheel backward while the gyro and the accelerometers see the body roll on undisturbed. Each wheel's
reading u_w is set against two witnesses of the ground's speed at its contact point (two against one):

(a) the other wheel and the gyro: v_pred = v_other +- (b (gyro - b_g) - D v_o) (encoders.predicted_increment);
(c) the accelerometers' tangential speed anchored where the wheels last agreed (ground_speed_update):
    v_g = the wheels' mean v_o while both encoders are healthy and agree with the gyro within
    stuck_min_speed + yaw_slip_fraction |v_R - v_L|; otherwise v_g integrates the healthy tangential
    accelerometers' mean a_t (the pair's centre, S(3): v_t' - v_n omega, the v_n omega term left out over
    the short spans it runs); the contact point's ground speed is v_g +- (gyro - b_g) b/2.

``inconsistent`` (counter_rotation_test): u_w runs against both witnesses (opposite signs, each beyond
stuck_min_speed) while the other wheel's does not, for COUNTER_ROTATION_FACTOR times the stuck test's
still samples in a row. Not flagged: a held wheel (it reads zero), a lifted or spinning wheel that turns
with the ground beneath it, a wheel whose partner disagrees too (both wheels' readings against the body:
the yaw test's and the perturbation monitor's matter). Without a healthy gyro or a tangential
accelerometer there is no test. The test judges sample by sample: on a stream that holds its angles
between readings (encoder_hold_time > 0, as imported logs do) a held sample reads its wheel still and
restarts the count, so that a flip there goes unseen. Mistaken for a lying encoder: a wheel its motor
holds turning backward against the ground for longer, on ice or lifted, while the other rolls with the
body; only the wheel-speed commands, which the checks do not read, could tell it apart (the perturbation
monitor's band). A skid-steer robot turns its inner wheels backward while the ground beneath their
geometric contact moves on: its model's track must be the effective one (slipnav calibrate), as its
odometry's must. The flagged encoder is excluded and replaced like any other (encoders.encoder_outputs),
and comes back through the re-admission block (encoders.readmission_block), which a sign-flipped count
never passes while it moves.
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.analog import body_acceleration
from slipnav.systems.health.encoders import predicted_increment
from slipnav.systems.health.layout import ENCODER_OPPOSED, ENCODER_SUSPECT, GROUND_SPEED
from slipnav.systems.health.parameters import FIRST_ENCODER, INCONSISTENT

COUNTER_ROTATION_FACTOR = 2
"""An encoder is flagged once it has read its wheel against the ground for this many times the stuck
test's still samples (encoder_stuck_samples) in a row: a wheel reversed against the ground by its motor
while the body slides on is dragged back by the tyre's full friction within milliseconds."""


@jitable
def wheel_speeds(inc, g) -> tuple:
    """The accepted increments ``inc`` (rad, NaN: none) as circumferential speeds (v_R, v_L) in the
    nominal radii (m/s)."""
    return inc[0] * g.radius_R / g.T_N, inc[1] * g.radius_L / g.T_N


@jitable
def ground_speed_update(
    s, raw, inc, gyro: float, radius_difference: float, gyro_ok: bool, codes, p, g
) -> None:
    """Witness (c) one T_N on (module docstring), in s[GROUND_SPEED] (m/s; NaN: no witness until the
    wheels agree again): anchored on the wheels' mean v_o when both encoders and the gyro are healthy
    (codes[5:7] 0, finite increments ``inc``, ``gyro_ok``) and their yaw residual v_R - v_L -
    b ``gyro`` + D v_o (gyro less b_g, rad/s; D ``radius_difference``) lies within stuck_min_speed +
    yaw_slip_fraction |v_R - v_L|; else advanced by T_N times the tangential accelerometers' mean
    (body_acceleration)."""
    v_R, v_L = wheel_speeds(inc, g)
    healthy = codes[FIRST_ENCODER] == 0 and codes[FIRST_ENCODER + 1] == 0
    if healthy and gyro_ok and math.isfinite(v_R + v_L + gyro):
        v_o = 0.5 * (v_R + v_L)
        residual = v_R - v_L - g.track_width * gyro + radius_difference * v_o
        if abs(residual) <= p.stuck_min_speed + p.yaw_slip_fraction * abs(v_R - v_L):
            s[GROUND_SPEED] = v_o
            return
    s[GROUND_SPEED] += g.T_N * body_acceleration(raw, codes, p)  # NaN stays NaN until anchored


@jitable
def counter_rotation_test(s, inc, gyro: float, radius_difference: float, gyro_ok: bool, codes, p, g) -> None:
    """The counter-rotation test on the accepted increments ``inc`` (rad) against witness (a) and the
    anchored s[GROUND_SPEED] (witness (c), as it stood before this sample; ``gyro`` less b_g, rad/s):
    a wheel flagged writes codes[5:7] INCONSISTENT, marks it suspect and drops its increment (NaN), so
    that it is replaced. The samples each wheel has read against the ground: s[ENCODER_OPPOSED]."""
    opposed = s[ENCODER_OPPOSED]
    suspect = s[ENCODER_SUSPECT]
    speeds = wheel_speeds(inc, g)
    v_g = s[GROUND_SPEED]
    against = [False, False]
    if gyro_ok and math.isfinite(speeds[0] + speeds[1] + v_g + gyro):
        radii = (g.radius_R, g.radius_L)
        for w in range(2):
            sign = 1.0 if w == 0 else -1.0
            witness_a = predicted_increment(w, inc[1 - w], gyro, radius_difference, g) * radii[w] / g.T_N
            witness_c = v_g + sign * gyro * 0.5 * g.track_width
            against[w] = runs_against(speeds[w], witness_a, witness_c, p.stuck_min_speed)
    samples = COUNTER_ROTATION_FACTOR * p.encoder_stuck_samples
    for w in range(2):
        if against[w] and not against[1 - w]:
            opposed[w] += 1.0
        else:
            opposed[w] = 0.0
        if opposed[w] >= samples:
            codes[FIRST_ENCODER + w], suspect[w], inc[w] = INCONSISTENT, 1.0, math.nan


@jitable
def runs_against(u: float, witness_a: float, witness_c: float, min_speed: float) -> bool:
    """The reading ``u`` runs against both witnesses of the ground beneath its wheel (m/s): opposite in
    sign to each, all three beyond ``min_speed`` in magnitude."""
    if min(abs(u), abs(witness_a), abs(witness_c)) <= min_speed:
        return False
    return u * witness_a < 0.0 and u * witness_c < 0.0
