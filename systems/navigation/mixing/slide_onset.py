"""The per-sample slide-onset test: at a slide's onset S(15) takes v_t from the inertial estimate alone
(C1 = 0) until the odometric and the inertial v_t agree again, while the accelerometer pair agrees with
itself.
"""

import math

from slipnav.systems.health.accelerometer_pair import pair_rotational_difference
from slipnav.systems.navigation.mixing.parameters import MixingParameters


def accelerometer_pair_disagreement(accelerometers, omega: float, position) -> float:
    """|a_t1 - a_t2 - (-2 omega^2 x)|: how far the two accelerometers' t axes (S(3): at +-(x, y))
    disagree beyond their centripetal difference (health.accelerometer_pair.pair_rotational_difference; the
    angular-acceleration term -2 omega_dot y is left in: it is part of what the tolerance allows). NaN if
    a reading is not finite."""
    return abs(accelerometers[0] - accelerometers[2] - pair_rotational_difference(omega, position)[0])


SLIDE_ONSET_INITIAL = (0, -10, math.nan)
"""slide_onset_step's initial state: released, armed after 10 samples (one Tinyphoon T_C)."""


def slide_onset_step(
    state,
    odo_v_t: float,
    inertial_v_t: float,
    inertial_a_t: float,
    disagreement: float,
    p: MixingParameters,
    T_N: float,
):
    """The per-sample wheel-speed test that hands S(15)'s v_t to the inertial estimate at a slide's onset
    (an extension of S(11)-(12): C1 follows S(11)'s batch of T_C, which sees a lock only at the batch's
    end and falls over three batches, 60 ms in which the mixed v_t follows the locked wheels).

    The test sets when the odometric v_t changes in one sample by more than slide_onset_jump beyond
    ^I a_t T_N (no body accelerates at that rate: the wheels left it); it holds while the odometric and
    the inertial v_t disagree, and releases after slide_onset_release_samples samples of agreement within
    slide_onset_release, after slide_onset_max_time, or at once while the accelerometers disagree with
    each other by slide_onset_pair_tolerance or more (``disagreement``,
    accelerometer_pair_disagreement; NaN counts as disagreeing). A non-finite odometric v_t (an encoder
    the sensor checks could not replace) neither sets it nor counts as agreement (the hold ages on), and
    the next finite one is not tested against it.

    Args:
        state: (count, age, previous odometric v_t): count 0 released, else 1 + samples of agreement
            so far; age the samples since it set, or, negative while released, the samples until the
            test arms (SLIDE_ONSET_INITIAL: the odometry's first speeds span an unknown previous angle,
            and the EKF's v_t reaches the odometry's through C1 within one T_C).

    Returns:
        (next state, True while set: C1 = 0 in S(15) for this sample)
    """
    count, age, previous = state
    if count == 0 and age < 0:  # arming
        return (0, age + 1, odo_v_t), False
    if not disagreement < p.slide_onset_pair_tolerance:
        return (0, 0, odo_v_t), False
    if not math.isfinite(odo_v_t):  # the hold ages on; the next finite speed has no previous one
        if count == 0:
            return (0, 0, math.nan), False
        age += 1
        if age * T_N > p.slide_onset_max_time:
            return (0, 0, math.nan), False
        return (count, age, math.nan), True
    if count == 0:
        if abs(odo_v_t - previous - inertial_a_t * T_N) > p.slide_onset_jump:  # False for NaN previous
            count, age = 1, 0
        else:
            return (0, 0, odo_v_t), False
    if abs(odo_v_t - inertial_v_t) < p.slide_onset_release:
        count = 0 if count >= p.slide_onset_release_samples else count + 1
    else:
        count = 1
    age += 1
    if age * T_N > p.slide_onset_max_time:
        count = 0
    return (count, age if count else 0, odo_v_t), count > 0
