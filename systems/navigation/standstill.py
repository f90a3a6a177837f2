"""Standstill as a measurement: the zero-velocity test, the zero-velocity update (ZUPT) and the
accelerometer biases a standstill observes (an extension of Seyr & Jakubek's Fig. 3).

Witnesses. The robot stands when the wheels and the accelerometers agree that it does (the
generalised likelihood-ratio detector of Skog et al., "Zero-velocity detection — an algorithm
evaluation", IEEE T-BME 2010, with the wheels as a second witness):

1. wheels: neither encoder angle (as the sensor checks pass it) has changed for ``still_time``;
2. accelerometers: T = z_t^2 + z_n^2 stays within the chi-square quantile of two degrees of freedom at
   1 - ``false_rejection``, where z is a PT1 average (time constant ``averaging_time``) of the pair's mean
   tangential and lateral acceleration less their estimated biases, divided by its standard deviation at
   rest: the white noise through the PT1, sigma^2 a / (2 - a) with a = T_N / (averaging_time + T_N),
   plus the bias estimates' own variance. Wheels that lock in a slide, or a body pushed while its wheels
   stand, fail this test: the body accelerates.

The gyro is not a witness here: two witnesses that agree outvote it, so that a gyro whose bias has
changed cannot keep the estimate integrating at rest. Its PT1 average at rest (``gyro_average`` of the
state) is the gyro's residual against the standstill; its bias is the yaw calibration's state.

ZUPT. While the robot stands the navigation's estimate [v_t, v_n, omega, a_t, a_n] is zero, a
measurement the velocity mixer (systems/navigation/mixing/mixer.py) applies to S(15)-(17)'s output, with the
gain 1 in the EKF's covariance (mixing_gain), so that the pose S(21) holds whatever the sensors' biases do.

Accelerometer biases. Each axis i of each accelerometer reads b_i plus white noise while the robot
stands; b_i is a random walk of the data sheet's drift density (m/s^2 per sqrt(s)). A scalar Kalman
filter per axis predicts P_i += q T_N every sample and, while standing, updates
K = P_i / (P_i + sigma_a^2), b_i += K (a_i - b_i), P_i -= K P_i. Every block after the sensor correction
reads a_i - b_i (the previous sample's b_i).
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import require_flag, require_in
from slipnav.systems.residual_test import chi_square_quantile

StandstillState = namedview(
    "StandstillState",
    [
        "still_samples",
        "theta_R",
        "theta_L",
        "gyro_average",
        "a_t_average",
        "a_n_average",
        "bias_t1",
        "bias_n1",
        "bias_t2",
        "bias_n2",
        "variance_t1",
        "variance_n1",
        "variance_t2",
        "variance_n2",
    ],
)
"""The standstill test's state: samples since an encoder angle last changed, the last angles (rad), the
PT1 averages (rad/s, m/s^2), the accelerometer biases (m/s^2) and their variances (m^2/s^4)."""

_FIELD = StandstillState._fields.index
_BIASES = slice(_FIELD("bias_t1"), _FIELD("bias_n2") + 1)
_VARIANCES = slice(_FIELD("variance_t1"), _FIELD("variance_n2") + 1)
_STILL, _THETA_R, _THETA_L = _FIELD("still_samples"), _FIELD("theta_R"), _FIELD("theta_L")
_AVERAGES = slice(_FIELD("gyro_average"), _FIELD("a_n_average") + 1)
"""The state's parts by index, for the per-sample functions (a namedview's attribute costs microseconds)."""


@dc.dataclass
class StandstillParameters:
    """Tuning of the zero-velocity test and update (module docstring).

    Args:
        enabled: test and update (False: the estimate integrates at rest as while moving, as in the paper).
        still_time: how long neither encoder may change before the wheels witness a standstill (s):
            0.05, many encoder counts at any speed the robots drive.
        averaging_time: the PT1 time constant of the inertial averages (s): 0.02.
        false_rejection: probability that the accelerometers' test rejects a true standstill in one sample
            (0, 1): 1e-3.
    """

    enabled: bool = True
    still_time: float = 0.05
    averaging_time: float = 0.02
    false_rejection: float = 1e-3

    def __post_init__(self):
        require_flag("standstill.enabled", self.enabled)
        for name in ("still_time", "averaging_time"):
            require_in(f"standstill.{name}", getattr(self, name), "(0, inf) s")
        require_in("standstill.false_rejection", self.false_rejection, "(0, 1)")


@dc.dataclass(frozen=True)
class StandstillConstants:
    """What the test computes once: sample counts, the PT1's gain and the data sheet's variances."""

    enabled: bool
    T_N: float
    still_samples: int
    average_gain: float
    gate: float
    accel_variance: float
    accel_mean_average_variance: float
    bias_drift_variance: float
    initial_bias_variance: float


def standstill_constants(p: StandstillParameters, geometry, T_N: float) -> StandstillConstants:
    """The constants for the nominal data sheet in ``geometry`` (health.HealthGeometry: the
    accelerometers' noise, drift density and initial bias)."""
    a = T_N / (p.averaging_time + T_N)
    through_average = a / (2.0 - a)
    accel_variance = geometry.accel_noise_std**2
    return StandstillConstants(
        enabled=p.enabled,
        T_N=T_N,
        still_samples=max(1, int(round(p.still_time / T_N))),
        average_gain=a,
        gate=chi_square_quantile(1.0 - p.false_rejection, 2),
        accel_variance=accel_variance,
        accel_mean_average_variance=0.5 * accel_variance * through_average,
        bias_drift_variance=geometry.accel_drift_density**2 * T_N,
        initial_bias_variance=geometry.accel_initial_bias_std**2,
    )


def standstill_initial_state(c: StandstillConstants) -> np.ndarray:
    """No standstill seen yet, zero averages, zero biases with the data sheet's initial variance."""
    state = StandstillState(np.zeros(len(StandstillState._fields)))
    state.theta_R = state.theta_L = math.nan
    state[_VARIANCES] = c.initial_bias_variance
    return state[:]


def accelerometer_biases(state) -> list:
    """[b_t1, b_n1, b_t2, b_n2] of a standstill state (m/s^2)."""
    return np.asarray(state, float)[_BIASES].tolist()


def bias_free(state, accelerometers) -> list:
    """[a_t1 - b_t1, a_n1 - b_n1, a_t2 - b_t2, a_n2 - b_n2] with the state's biases."""
    b_t1, b_n1, b_t2, b_n2 = accelerometer_biases(state)
    a_t1, a_n1, a_t2, a_n2 = [float(a) for a in accelerometers]
    return [a_t1 - b_t1, a_n1 - b_n1, a_t2 - b_t2, a_n2 - b_n2]


def standstill_test(state, free_accelerometers, gyro: float, encoders, c):
    """(standing, [still samples, gyro average, a_t average, a_n average] after this sample).

    ``free_accelerometers``: bias_free's readings; ``gyro``: the calibrated gyro (rad/s), averaged as
    the gyro's residual; ``encoders``: the checked angles (rad)."""
    s = np.asarray(state, float).tolist()
    unchanged = encoders[0] == s[_THETA_R] and encoders[1] == s[_THETA_L]
    still = s[_STILL] + 1.0 if unchanged else 0.0
    a = c.average_gain
    mean_t = 0.5 * (free_accelerometers[0] + free_accelerometers[2])
    mean_n = 0.5 * (free_accelerometers[1] + free_accelerometers[3])
    gyro_average, a_t_average, a_n_average = s[_AVERAGES]
    averages = (
        gyro_average + a * (gyro - gyro_average),
        a_t_average + a * (mean_t - a_t_average),
        a_n_average + a * (mean_n - a_n_average),
    )
    if not c.enabled or still < c.still_samples:
        return False, [still, *averages]
    variances = s[_VARIANCES]
    statistic = (
        averages[1] ** 2 / (c.accel_mean_average_variance + 0.25 * (variances[0] + variances[2]))
        + averages[2] ** 2 / (c.accel_mean_average_variance + 0.25 * (variances[1] + variances[3]))
    )
    return bool(statistic <= c.gate), [still, *averages]


def standstill_step(state, accelerometers, encoders, standing: bool, test, c) -> np.ndarray:
    """The state after this sample: ``test`` (standstill_test's second value), the encoders' angles and
    the biases' Kalman filter (predict; update from the raw ``accelerometers`` while ``standing``)."""
    next_state = np.asarray(state, float).tolist()  # element by element, as floats
    next_state[_STILL] = float(test[0])
    next_state[_AVERAGES] = [float(a) for a in test[1:4]]
    next_state[_THETA_R], next_state[_THETA_L] = float(encoders[0]), float(encoders[1])
    # predict step: each bias a random walk of the data sheet's drift
    variances = [v + c.bias_drift_variance for v in next_state[_VARIANCES]]
    biases = next_state[_BIASES]
    if standing:
        # update step: at rest each axis reads its bias plus white noise
        gains = [v / (v + c.accel_variance) for v in variances]
        biases = [b + k * (float(a) - b) for b, k, a in zip(biases, gains, accelerometers, strict=True)]
        variances = [(1.0 - k) * v for k, v in zip(gains, variances, strict=True)]
    next_state[_BIASES], next_state[_VARIANCES] = biases, variances
    return np.array(next_state)


def zero_velocity_update(mixed, check_state):
    """The ZUPT: the estimate [v_t, v_n, omega, a_t, a_n] is zero, and the tyre-model check's free
    integral F and curve S (mixing.mix_checked's state) restart from rest; the rest of that state stays."""
    return np.zeros(5), (0.0, 0.0, *check_state[2:])


STANDSTILL_STEP_LAYOUT = (("accelerometers", 4), ("standstill", 1), ("test", 4), ("accelerometer_bias", 4))
"""StandstillDetector's ``step`` output, in order: (name, size); diagrams/split.py slices it."""
_STEP_START = {
    name: sum(size for _, size in STANDSTILL_STEP_LAYOUT[:i])
    for i, (name, _) in enumerate(STANDSTILL_STEP_LAYOUT)
}
_STANDING, _TEST = _STEP_START["standstill"], slice(_STEP_START["test"], _STEP_START["accelerometer_bias"])


class StandstillDetector(LeafSystem):
    """The zero-velocity test and the accelerometer biases it observes (module docstring).

    .. pydrake_system::

        name: StandstillDetector
        input_ports:
        - accelerometers
        - gyro
        - encoders
        output_ports:
        - step

    - accelerometers: the checked and corrected [a_t1, a_n1, a_t2, a_n2] (m/s^2).
    - gyro: the calibrated gyro [omega - b_g] (rad/s); encoders: the checked angles [theta_R, theta_L]
      (rad).
    - step (direct feedthrough), in STANDSTILL_STEP_LAYOUT's order: accelerometers, the readings less
      the biases after the previous sample (bias_free), what every later block reads; standstill, [1
      while the robot stands, else 0] (standstill_test); test, the test's state after this sample;
      accelerometer_bias, [b_t1, b_n1, b_t2, b_n2] (m/s^2) after the previous sample. One vector, one
      Python call per sample; the navigation diagram slices it (diagrams/split.py).

    Update every T_N: standstill_step from the ``step`` output.

    Args:
        constants: standstill_constants.
    """

    def __init__(self, constants: StandstillConstants):
        super().__init__()
        self._c = constants
        self._acc = self.DeclareVectorInputPort("accelerometers", 4)
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        self._enc = self.DeclareVectorInputPort("encoders", 2)
        self._state = self.DeclareDiscreteState(standstill_initial_state(constants))
        self._step = self.DeclareVectorOutputPort(
            "step", sum(size for _, size in STANDSTILL_STEP_LAYOUT), self._calc_step
        )
        self.DeclarePeriodicDiscreteUpdateEvent(constants.T_N, 0.0, self._update)

    def _calc_step(self, context, output):
        state = context.get_discrete_state(self._state).get_value()
        free = bias_free(state, self._acc.Eval(context))
        standing, test = standstill_test(
            state,
            free,
            float(self._gyro.Eval(context)[0]),
            self._enc.Eval(context).tolist(),
            self._c,
        )
        output.SetFromVector([*free, 1.0 if standing else 0.0, *test, *accelerometer_biases(state)])

    def _update(self, context, discrete_state):
        step = self._step.Eval(context)
        state = standstill_step(
            context.get_discrete_state(self._state).get_value(),
            self._acc.Eval(context).tolist(),
            self._enc.Eval(context).tolist(),
            step[_STANDING] > 0.5,
            step[_TEST].tolist(),
            self._c,
        )
        discrete_state.set_value(self._state, state)
