"""Online calibration of the gyro against the odometry: the gyro bias and the wheels' rolling-radius
difference (an extension of Seyr & Jakubek's Fig. 3, in the spirit of Gyrodometry's drift learning,
Indiveri et al. Algorithm 1, and of Borenstein & Feng's UMBmark correction of unequal wheel diameters).

With the real rolling radii r_R = r (1 + e_R), r_L = r (1 + e_L) and the nominal odometry S(10) (v_o,
omega_o) the robot's yaw rate while the wheels roll is

    omega = [b omega_o (1 + (e_R + e_L)/2) + (e_R - e_L) v_o] / b',

so a robot that drives straight (omega = 0) shows an odometric yaw rate -D v_o / b with D ~ e_R - e_L:
a 1 % larger right wheel on Tinyphoon reads 0.23 rad/s at 1.6 m/s. A gyro-bias estimate that learns
gyro - omega_o while driving straight takes that for gyro bias, and the heading follows it. Here, per
batch of T_C/T_N samples (means: the encoders' quantisation telescopes to one count per batch),

    gyro - omega_o = b_g + D v_o / b      (while omega = 0),

a model linear in theta = [b_g, D], estimated by a Kalman filter (recursive least squares with the
bias's random walk) from the batches whose data pass every plausibility check: no sensor fault, C1 >=
trusted_c1 on every sample (no tangential slip), the gyro less the bias below straight_yaw_rate (driving
straight or standing still), and an innovation within innovation_gate sigmas. At standstill the row is
[1, 0]: the bias alone, the data sheet's way to learn it; driving at varying speed separates the two.
At constant speed they cannot be told apart, so every run begins with a standstill (the scenario's
standstill_time, 1 s) that pins the bias before D is learned, and D, a constant of the robot, has no
random walk that would let it soak up the bias's later drift.

The yaw-rate scale (track width, gyro sensitivity) is not learned: in turns the odometric yaw rate leads
the gyro by the wheels' differential slip that every yaw acceleration and the shoes' scrub need
(Tinyphoon's corner: 10-15 % at turn-in), so a scale fitted there absorbs the robot's dynamics, not its
geometry; turns are the gyro's (C3 S(14)).

A change of the gyro's bias (a step, or a drift faster than its random walk) is judged by one test on
the filter's innovation (systems/residual_test.py): a two-sided CUSUM over the batches that both
witnesses allow, the wheels saying the robot drives straight (change_yaw_rate) with wheels and gyro
steady since the previous batch (steady_yaw_acceleration) and the gyro within the band of the largest
bias step, or a rest the standstill detector confirms (a batch without encoder counts the detector does
not confirm is neither learned from nor tested: the counts lag a turn's start or end), where D's
uncertainty adds less to the innovation than the noise does ((v/b)^2 P_DD <= R: until the radius
difference is learned, a residual at speed may be D's). The innovation is
normalised by the larger of its predicted S and the variance the healthy tested batches show
(noise_batches), and clipped at change_clip. On an alarm the estimate returns to the CUSUM's change
point, where the N batches since measure the change (their mean residual m against theta there; what
was learned from them meanwhile, mostly by D at speed, is set aside): b_g's variance widens by m^2 and
the mean updates it with R / N (systems/navigation/bias_change.py). The learning gate (straight_yaw_rate,
innovation_gate) keeps reading the gyro less the new b_g. A gyro whose scale or sign fails shows only in
turns, where the health layer's yaw test judges it; when that test blames the gyro, theta and P return to
the estimate the witnesses last confirmed (systems/navigation/confirmed_estimate.py).
A healthy stream raises one false alarm per change_run_length tested batches.

The navigation reads the calibrated gyro gyro - b_g and the calibrated odometric yaw rate
omega_o + D v_o / b, the latter in S(14)'s mix with the share that theta's covariance gives it
(systems/navigation/calibrated_signals.py); the baselines (odometry-only, Gyrodometry) keep the raw
signals. A moving batch's measurement variance is the larger of measurement_std^2 and what its residuals
show, plus what the tyres' differential slip at the batch's yaw acceleration may add
(systems/navigation/calibration_batches.py).
"""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.navigation.bias_change import (
    CHANGE_STATE_SIZE,
    NUM_THETA,
    bias_change_test,
    bias_change_update,
    bias_step_update,
    change_points_age,
    change_points_step,
)
from slipnav.systems.navigation.calibrated_signals import (
    calibrated_gyro,
    calibrated_odometry,
    odometric_yaw_share,
)
from slipnav.systems.navigation.calibration_batches import (
    batch_selection,
    believed_gyro,
    measurement_variance,
    observed_variance_step,
    slip_variance,
)
from slipnav.systems.navigation.confirmed_estimate import (
    CONFIRMED_SIZE,
    confirm_batch,
    confirmed_estimate,
    confirmed_initial_state,
    note_verdict,
)
from slipnav.systems.navigation.yaw_calibration_parameters import YawCalibrationParameters
from slipnav.systems.residual_test import CUSUM_SIZE, CusumState, cusum_step
from slipnav.systems.robot.sensors import SensorParameters
from slipnav.systems.state_layout import layout_size, layout_slices

CALIBRATION_LAYOUT = (
    ("theta", 2),
    ("covariance", 4),
    ("sums", 4),
    ("count", 1),
    ("ok", 1),
    ("learned", 1),
    ("rejected", 1),
    ("cusum", CUSUM_SIZE),
    ("changes", 1),
    ("previous_wheels", 1),
    ("previous_gyro", 1),
    ("standing", 1),
    ("witnessed", 1),
    ("residual_variance", 1),
    ("moving_variance", 1),
    ("change_points", CHANGE_STATE_SIZE),
    ("confirmed", CONFIRMED_SIZE),
)
"""The calibration's state, in order (name, size): theta = [b_g, D], its covariance P (row-major), the
batch's sums of (gyro, omega_o, v_o, |v_o| + |omega_o|), its sample count, 1 while every sample of the
batch passed its checks, the learned and rejected batches, the bias-change CUSUM (CusumState), the bias
changes detected, the previous batch's calibrated odometric yaw rate and gyro mean (NaN: none), the
batch's samples the standstill detector called standing, those on which the accelerometer pair witnessed
the yaw rate (third_witness), the observed variance of the tested batches' innovations and the learned
moving batches' observed measurement variance (rad^2/s^2; 0: none yet), the bias-change test's change
points (bias_change.CHANGE_LAYOUT), the estimate the witnesses last confirmed
(confirmed_estimate.CONFIRMED_LAYOUT)."""


_SLICES = layout_slices(CALIBRATION_LAYOUT)
_THETA, _P, _SUMS, _COUNT, _OK = (_SLICES[k] for k in ("theta", "covariance", "sums", "count", "ok"))
_LEARNED, _REJECTED, _CUSUM, _CHANGES = (_SLICES[k] for k in ("learned", "rejected", "cusum", "changes"))
_PREVIOUS_WHEELS, _PREVIOUS_GYRO = _SLICES["previous_wheels"], _SLICES["previous_gyro"]
_STANDING, _RESIDUAL_VARIANCE = _SLICES["standing"], _SLICES["residual_variance"]
_WITNESSED, _MOVING_VARIANCE = _SLICES["witnessed"], _SLICES["moving_variance"]
_CHANGE_POINTS, _CONFIRMED = _SLICES["change_points"], _SLICES["confirmed"]
STATE_SIZE = layout_size(CALIBRATION_LAYOUT)


def yaw_calibration_initial_state(p: YawCalibrationParameters) -> np.ndarray:
    """theta = [0, 0], P = diag(prior variances), empty batch (believed_gyro's priors)."""
    p = believed_gyro(p)
    state = np.zeros(STATE_SIZE)
    state[_P] = np.diag([p.initial_bias_std**2, p.initial_radius_difference_std**2]).ravel()
    state[_OK] = 1.0
    state[_PREVIOUS_WHEELS] = state[_PREVIOUS_GYRO] = math.nan
    state[_CONFIRMED] = confirmed_initial_state(state[_THETA], state[_P])
    return state


def yaw_calibration_step(
    state,
    gyro: float,
    odo,
    c1: float,
    fault: bool,
    track_width: float,
    p: YawCalibrationParameters,
    T_N: float,
    batch_length: int,
    standing: bool | None = None,
    bias_step: float = 0.0,
    third_witness: bool = True,
    verdict: float = 0.0,
) -> np.ndarray:
    """One T_N sample: accumulate the batch; at its end (batch_length samples) the Kalman update of theta
    if every check passed. ``standing``: the standstill detector's decision for this sample
    (systems/navigation/standstill.py; None: without the detector the wheels alone say the robot stands). A
    batch whose wheels did not turn counts as a standstill only while the detector said so on every sample;
    otherwise (the wheels' counts lag a turn's start or end) it is neither learned from nor tested.
    ``bias_step``: a step of b_g the sensor checks measured on an excluded gyro (rad/s, 0: none;
    systems/health/gyro.py, gyro_bias_step_block), taken as a bias change (bias_step_update with R =
    measurement_std^2) at once. ``third_witness``: the accelerometer pair witnesses the yaw rate on this
    sample (the sensor checks' yaw_pair_witness: two sensors, finite, none excluded), so that the checks
    exclude a wheel whose yaw disagrees with gyro and pair; a moving batch is tested for a change only when
    the pair witnessed every one of its samples, else its change is the wheels' as likely as the gyro's (a
    rest's is tested: there the standstill detector witnesses too). ``verdict``: the health layer's yaw
    test on this sample (layout.yaw_verdict: 1 confirmed the gyro, -1 blamed it, 0 did not judge); a
    blame returns theta and P to the estimate the witnesses last confirmed (confirmed_estimate.py).
    Returns the next state (the theta used at this sample is ``state``'s)."""
    state = np.array(state, dtype=float)
    if not p.enabled:
        return state
    if bias_step != 0.0 and math.isfinite(bias_step):
        P = state[_P].reshape(NUM_THETA, NUM_THETA)
        theta, P = bias_step_update(state[_THETA], P, bias_step, p.measurement_std**2)
        state[_THETA], state[_P] = theta, P.ravel()
        state[_CUSUM] = 0.0
        state[_CHANGES] += 1.0
    if verdict < 0.0:  # the yaw test blames the gyro: back to the confirmed estimate
        theta, P = confirmed_estimate(state[_CONFIRMED], _batch_walk(believed_gyro(p), batch_length * T_N))
        state[_THETA], state[_P] = theta, P.ravel()
        state[_CUSUM] = state[_CHANGE_POINTS] = 0.0
        state[_PREVIOUS_WHEELS] = state[_PREVIOUS_GYRO] = math.nan
    note_verdict(state[_CONFIRMED], verdict)
    v, omega_o = odo[0], odo[1]
    sample_ok = not fault and c1 >= p.trusted_c1 and all(map(math.isfinite, (gyro, v, omega_o)))
    values = memoryview(state)  # the per-sample counts element by element, as Python floats
    if sample_ok:
        sums = values[_SUMS]
        sums[0] += gyro
        sums[1] += omega_o
        sums[2] += v
        sums[3] += abs(v) + abs(omega_o)
    else:
        values[_OK] = 0.0
    values[_COUNT] += 1.0
    values[_STANDING] += 1.0 if standing is None or standing else 0.0
    values[_WITNESSED] += 1.0 if third_witness else 0.0
    if values[_COUNT] < batch_length:
        return state
    return batch_update(state, track_width, p, T_N)


def batch_update(state, track_width: float, p: YawCalibrationParameters, T_N: float):
    """A batch's end (yaw_calibration_step): the random walks' prediction, the batch's selection, the
    bias-change test and the Kalman update of theta; the batch's sums restart. Returns ``state``."""
    n = state[_COUNT]
    gyro_mean, omega_mean, v_mean, moving = state[_SUMS] / n
    theta, P = state[_THETA].copy(), state[_P].reshape(NUM_THETA, NUM_THETA)
    # predict step: the random walks over the batch
    p = believed_gyro(p)
    walk = _batch_walk(p, n * T_N)
    P = P + walk
    change_points_age(state[_CHANGE_POINTS], CusumState(state[_CUSUM]))
    wheels = omega_mean + theta[1] * v_mean / track_width  # the calibrated odometric yaw rate
    change = p.steady_yaw_acceleration * n * T_N  # both witnesses' yaw rates steady since the last batch
    steady = (
        abs(wheels - state[_PREVIOUS_WHEELS]) <= change and abs(gyro_mean - state[_PREVIOUS_GYRO]) <= change
    )
    slip = slip_variance(p.yaw_slip_time, v_mean, (gyro_mean - state[_PREVIOUS_GYRO]) / (n * T_N))
    state[_PREVIOUS_WHEELS] = wheels if state[_OK] > 0.5 else math.nan
    state[_PREVIOUS_GYRO] = gyro_mean if state[_OK] > 0.5 else math.nan
    learn, test = batch_selection(gyro_mean - theta[0], wheels, moving > 0.0, steady, p)
    test = test and (state[_WITNESSED] == n or moving == 0.0)  # the pair witnessed every sample
    witnessed = moving > 0.0 or state[_STANDING] == n  # a rest the detector confirms
    if state[_OK] > 0.5 and witnessed and (learn or test):
        H = np.array([1.0, v_mean / track_width])
        R = (p.measurement_std if moving > 0.0 else p.standstill_measurement_std) ** 2
        noise = R  # the batches' noise, without the tyres' slip
        if moving > 0.0:  # the residuals' noise and the tyres' slip (calibration_batches.py)
            noise = measurement_variance(R, state[_MOVING_VARIANCE])
            R = noise + slip
        innovation = gyro_mean - omega_mean - H @ theta
        S = H @ P @ H + R
        if learn and moving > 0.0:
            state[_MOVING_VARIANCE] = observed_variance_step(
                state[_MOVING_VARIANCE], innovation, S - noise, S, p.innovation_gate, p.noise_batches
            )
        alarm = 0
        # the test judges b_g only where D's uncertainty adds less to the innovation than the noise does
        if test and H[1] * H[1] * P[1, 1] <= noise:
            # test: the CUSUM of the innovation normalised by the larger of its predicted variance and
            # the variance the healthy tested batches show (a real robot's witnesses are noisier)
            z = innovation / math.sqrt(max(S, state[_RESIDUAL_VARIANCE]))
            if z * z <= p.innovation_gate**2:
                state[_RESIDUAL_VARIANCE] += (innovation**2 - state[_RESIDUAL_VARIANCE]) / p.noise_batches
            cusum, alarm = cusum_step(CusumState(state[_CUSUM]), z, bias_change_test(p))
            state[_CUSUM] = cusum[:]
            change_points_step(state[_CHANGE_POINTS], cusum, theta, P, gyro_mean - omega_mean, H[1])
            if alarm:  # measured from the change point (systems/navigation/bias_change.py)
                theta, P = bias_change_update(state[_CHANGE_POINTS], cusum, alarm, noise, walk)
                state[_CUSUM] = 0.0
                state[_CHANGES] += 1.0
                state[_LEARNED] += 1.0
                learn = False  # this batch is part of the change's evidence
        if learn and innovation * innovation <= p.innovation_gate**2 * S:
            # update step
            gain = P @ H / S
            theta = theta + gain * innovation
            I_KH = np.eye(NUM_THETA) - np.outer(gain, H)
            P = I_KH @ P @ I_KH.T + np.outer(gain, gain) * R
            state[_LEARNED] += 1.0
        elif learn:
            state[_REJECTED] += 1.0
    state[_THETA] = theta
    state[_P] = (0.5 * (P + P.T)).ravel()
    rest = moving == 0.0 and witnessed  # a rest the detector confirms
    confirm_batch(state[_CONFIRMED], theta, state[_P], state[_OK] < 0.5, rest)
    state[_SUMS] = 0.0
    state[_COUNT] = state[_STANDING] = state[_WITNESSED] = 0.0
    state[_OK] = 1.0
    return state


def _batch_walk(p: YawCalibrationParameters, duration: float) -> np.ndarray:
    """The random walks' covariance of theta over ``duration`` (s): diag(bias, D) densities squared
    (``p`` with the believed gyro's figures filled in: believed_gyro)."""
    return np.diag([p.bias_drift_density**2, p.radius_drift_density**2]) * duration


def calibration_parameters(state) -> list:
    """[b_g, D, sigma(b_g), sigma(D), learned batches, rejected batches, bias changes detected] of a
    calibration state."""
    values = np.asarray(state, float).tolist()  # element by element, as floats
    P = values[_P]  # row-major
    counts = [values[_LEARNED], values[_REJECTED], values[_CHANGES]]
    return [*values[_THETA], math.sqrt(P[0]), math.sqrt(P[NUM_THETA + 1]), *counts]


PARAMETERS_LAYOUT = (("estimate", 2), ("std", 2), ("batches", 3))
"""YawRateCalibration's ``parameters`` output (calibration_parameters), in order: (name, size)."""
CALIBRATED_LAYOUT = (("gyro", 1), ("odometry", 4), ("odometry_share", 1))
"""YawRateCalibration's ``calibrated`` output, in order: (name, size); diagrams/split.py slices it."""


class YawRateCalibration(LeafSystem):
    """Gyro bias and rolling-radius difference learned online (module docstring); outputs the calibrated
    gyro for the EKF and the calibrated odometry for the fusion.

    .. pydrake_system::

        name: YawRateCalibration
        input_ports:
        - gyro
        - odometry
        - C1
        - inertial_fault
        - encoder_fault
        - standstill
        - gyro_bias_step
        - yaw_pair_witness
        - yaw_verdict
        output_ports:
        - calibrated
        - bias
        - parameters

    - gyro: the checked gyro sample [omega] (rad/s); odometry: the nominal S(10) [^O v_t, ^O omega, v_R,
      v_L]; C1: the C1 in force; inertial_fault, encoder_fault: 1 when this sample's reading was replaced
      (its batch is not learned from); standstill (optional): 1 while the standstill detector says the
      robot stands (unconnected: the wheels alone say so, yaw_calibration_step's ``standing`` None);
      gyro_bias_step (optional): the step of b_g the sensor checks measured on an excluded gyro (rad/s;
      0 or unconnected: none), added at once; yaw_pair_witness (optional): 1 when the accelerometer pair
      witnessed this sample's yaw rate (the sensor checks' decision; unconnected: the believed sensor
      set has two accelerometer sets); yaw_verdict (optional): the health layer's yaw test on the gyro
      (1 confirmed, -1 blamed, 0 or unconnected: not judged), yaw_calibration_step's ``verdict``.
    - calibrated (direct feedthrough, theta and P from the state), in CALIBRATED_LAYOUT's order: gyro
      [omega - b_g]; odometry, calibrated_odometry; odometry_share, the odometric yaw rate's share in
      S(14)'s mix (odometric_yaw_share, systems/navigation/calibrated_signals.py). One vector, one
      Python call per sample; the navigation diagram slices it with a Demultiplexer (diagrams/split.py).
    - bias: [b_g] (rad/s, state).
    - parameters: calibration_parameters (state).

    Update every T_N: yaw_calibration_step (the Kalman update at each batch's end); at a batch's end the
    update also stores the new state's bias and calibration_parameters, which the outputs hold (no Python
    call; theta, P and the batch counts change only there).

    Args:
        params: YawCalibrationParameters. track_width: the nominal track (m). T_N, T_C: periods (s).
        sensors: the believed sensor set (None: the nominal SensorParameters()): the gyro's data sheet
            (believed_gyro), and while yaw_pair_witness is unconnected whether the accelerometer pair
            witnesses the yaw rate (two sets; yaw_calibration_step's third_witness).
    """

    def __init__(
        self,
        params: YawCalibrationParameters,
        track_width: float,
        T_N: float,
        T_C: float,
        sensors: SensorParameters | None = None,
    ):
        super().__init__()
        sensors = sensors or SensorParameters()
        params = believed_gyro(params, sensors)
        self._p, self._b, self._T_N = params, track_width, T_N
        self._third_witness = sensors.accelerometer_sets == 2
        self._n = int(round(T_C / T_N))
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._faults = [self.DeclareVectorInputPort(name, 1) for name in ("inertial_fault", "encoder_fault")]
        self._standstill = self.DeclareVectorInputPort("standstill", 1)
        self._bias_step = self.DeclareVectorInputPort("gyro_bias_step", 1)
        self._pair_witness = self.DeclareVectorInputPort("yaw_pair_witness", 1)
        self._verdict = self.DeclareVectorInputPort("yaw_verdict", 1)
        state0 = yaw_calibration_initial_state(params)
        self._state = self.DeclareDiscreteState(state0)
        parameters0 = calibration_parameters(state0)
        self._bias = self.DeclareDiscreteState(np.array(parameters0[0:1], float))
        self._parameters = self.DeclareDiscreteState(np.array(parameters0, float))
        self.DeclareVectorOutputPort(
            "calibrated",
            layout_size(CALIBRATED_LAYOUT),
            self._calc_calibrated,
            prerequisites_of_calc={self.xd_ticket(), self._gyro.ticket(), self._odo.ticket()},
        )
        self.DeclareStateOutputPort("bias", self._bias)
        self.DeclareStateOutputPort("parameters", self._parameters)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_calibrated(self, context, output):
        state = context.get_discrete_state(self._state).get_value()
        theta, odo = state[_THETA].tolist(), self._odo.Eval(context).tolist()
        gyro = calibrated_gyro(float(self._gyro.Eval(context)[0]), theta, self._p)
        share = odometric_yaw_share(state[_P].tolist(), odo[0], self._b, self._p, self._T_N)
        output.SetFromVector([gyro, *calibrated_odometry(odo, theta, self._b, self._p), share])

    def _update(self, context, discrete_state):
        inertial, encoder = self._faults
        fault = inertial.Eval(context).tolist()[0] > 0.5 or encoder.Eval(context).tolist()[0] > 0.5
        port = self._bias_step
        step = float(port.Eval(context)[0]) if port.HasValue(context) else 0.0
        port = self._pair_witness
        witness = port.Eval(context).tolist()[0] > 0.5 if port.HasValue(context) else self._third_witness
        verdict = self._verdict.Eval(context).tolist()[0] if self._verdict.HasValue(context) else 0.0
        state = yaw_calibration_step(
            discrete_state.get_value(self._state),
            self._gyro.Eval(context).tolist()[0],
            self._odo.Eval(context).tolist(),
            self._c1.Eval(context).tolist()[0],
            fault,
            self._b,
            self._p,
            self._T_N,
            self._n,
            self._standstill.Eval(context).tolist()[0] > 0.5 if self._standstill.HasValue(context) else None,
            step,
            witness,
            verdict,
        )
        discrete_state.set_value(self._state, state)
        if state[_COUNT] == 0.0 or step != 0.0 or verdict < 0.0:  # a batch ended, a bias step, a blame
            parameters = calibration_parameters(state)
            discrete_state.set_value(self._bias, parameters[0:1])
            discrete_state.set_value(self._parameters, parameters)
