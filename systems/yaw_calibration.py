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
random walk that would let it soak up the bias's later drift (matched robot, 3 seeds: long path
0.9-2.3 % -> 0.1-0.5 %, corner 0.15-0.22 % -> 0.07-0.25 %).

The yaw-rate scale (track width, gyro sensitivity) is not learned: in turns the odometric yaw rate leads
the gyro by the wheels' differential slip that every yaw acceleration and the shoes' scrub need
(Tinyphoon's corner: 10-15 % at turn-in), so a scale fitted there absorbs the robot's dynamics, not its
geometry; turns are the gyro's (C3 S(14)).

The navigation reads the calibrated gyro gyro - b_g and the calibrated odometric yaw rate
omega_o + D v_o / b; the baselines (odometry-only, Gyrodometry) keep the raw signals.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem


@dc.dataclass
class YawCalibrationParameters:
    """Tuning of the online gyro/odometry calibration.

    Args:
        enabled: calibrate (False: the EKF gets the raw gyro and the mixer the raw odometry, as in the
            paper).
        initial_bias_std: prior standard deviation of the gyro bias (rad/s): the ADXRS300's residual
            0.2 deg/s = 0.0035.
        initial_radius_difference_std: prior standard deviation of D = e_R - e_L: 0.0082, each rolling
            radius uniform within +-1 % of the nominal (scenarios/tolerances.py), 0.01 sqrt(2/3).
        bias_drift_density: random walk of the bias (rad/s per sqrt(s)): the gyro's 0.0005.
        radius_drift_density: random walk of D (1 per sqrt(s)): 0, the rolling radii are constant over a
            run (tyre wear acts over hours). Above 0, D follows whatever the bias's drift hands it at
            constant speed, where b_g and D v/b cannot be told apart.
        measurement_std: standard deviation of a moving batch's residual (rad/s): 0.01, the gyro's noise
            over a batch (0.014/sqrt(10)) and one encoder count per batch (Tinyphoon 0.005 rad/s), with
            margin.
        standstill_measurement_std: the same at standstill (no encoder count in the batch; rad/s): 0.005,
            the gyro's noise over a batch alone, with margin. A 1 s standstill learns the bias to ~0.7
            mrad/s before the robot moves, which D then cannot absorb.
        innovation_gate: a batch whose innovation exceeds this many sigmas is not learned from: 4.
        trusted_c1: C1 S(12) at or above which the odometry has no tangential slip: 0.9.
        straight_yaw_rate: |batch mean of gyro - b_g| below which the robot drives straight (rad/s):
            0.05, > 10 sigma of the batch's gyro noise, so that the gate does not select on the noise.
    """

    enabled: bool = True
    initial_bias_std: float = 0.0035
    initial_radius_difference_std: float = 0.0082
    bias_drift_density: float = 0.0005
    radius_drift_density: float = 0.0
    measurement_std: float = 0.01
    standstill_measurement_std: float = 0.005
    innovation_gate: float = 4.0
    trusted_c1: float = 0.9
    straight_yaw_rate: float = 0.05

    def __post_init__(self):
        if not isinstance(self.enabled, bool):
            raise ValueError(f"yaw_calibration.enabled={self.enabled!r} is out of range: allowed true, false")
        positive = (
            "initial_bias_std initial_radius_difference_std measurement_std standstill_measurement_std "
            "innovation_gate straight_yaw_rate"
        ).split()
        for name in positive:
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"yaw_calibration.{name}={v!r} is out of range: allowed (0, inf)")
        for name in ("bias_drift_density", "radius_drift_density"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"yaw_calibration.{name}={v!r} is out of range: allowed [0, inf)")
        if not (0.0 <= self.trusted_c1 <= 1.0):
            raise ValueError(
                f"yaw_calibration.trusted_c1={self.trusted_c1!r} is out of range: allowed [0, 1]"
            )


# State layout: theta = [b_g, D] (2), P (4, row-major), batch sums of (gyro, omega_o, v_o, |v_o| +
# |omega_o|) (4), batch sample count, 1 while every sample of the batch passed its checks, learned
# batches, rejected batches.
_THETA, _P, _SUMS, _COUNT, _OK, _LEARNED, _REJECTED = slice(0, 2), slice(2, 6), slice(6, 10), 10, 11, 12, 13
STATE_SIZE = 14


def yaw_calibration_initial_state(p: YawCalibrationParameters) -> np.ndarray:
    """theta = [0, 0], P = diag(prior variances), empty batch."""
    state = np.zeros(STATE_SIZE)
    state[_P] = np.diag([p.initial_bias_std**2, p.initial_radius_difference_std**2]).ravel()
    state[_OK] = 1.0
    return state


def calibrated_gyro(gyro: float, theta, p: YawCalibrationParameters) -> float:
    """gyro - b_g; the raw gyro when calibration is off."""
    return gyro - theta[0] if p.enabled else gyro


def calibrated_odometry(odo, theta, track_width: float, p: YawCalibrationParameters) -> list:
    """[v_o, omega, v_R, v_L] with omega = omega_o + D v_o / b and the wheel speeds v_o +- omega b/2 that
    give it; the raw odometry when calibration is off."""
    if not p.enabled:
        return list(odo)
    v = odo[0]
    omega = odo[1] + theta[1] * v / track_width
    half = 0.5 * track_width
    return [v, omega, v + omega * half, v - omega * half]


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
) -> np.ndarray:
    """One T_N sample: accumulate the batch; at its end (batch_length samples) the Kalman update of theta
    if every check passed. Returns the next state (the theta used at this sample is ``state``'s)."""
    state = np.array(state, dtype=float)
    if not p.enabled:
        return state
    v, omega_o = odo[0], odo[1]
    sample_ok = not fault and c1 >= p.trusted_c1 and all(map(math.isfinite, (gyro, v, omega_o)))
    if sample_ok:
        state[_SUMS] += [gyro, omega_o, v, abs(v) + abs(omega_o)]
    else:
        state[_OK] = 0.0
    state[_COUNT] += 1.0
    if state[_COUNT] < batch_length:
        return state
    n = state[_COUNT]
    gyro_mean, omega_mean, v_mean, moving = state[_SUMS] / n
    theta, P = state[_THETA].copy(), state[_P].reshape(2, 2)
    P = P + np.diag([p.bias_drift_density**2, p.radius_drift_density**2]) * (n * T_N)
    if state[_OK] > 0.5 and abs(gyro_mean - theta[0]) <= p.straight_yaw_rate:
        H = np.array([1.0, v_mean / track_width])
        R = (p.measurement_std if moving > 0.0 else p.standstill_measurement_std) ** 2
        innovation = gyro_mean - omega_mean - H @ theta
        S = H @ P @ H + R
        if innovation * innovation <= p.innovation_gate**2 * S:
            gain = P @ H / S
            theta = theta + gain * innovation
            I_KH = np.eye(2) - np.outer(gain, H)
            P = I_KH @ P @ I_KH.T + np.outer(gain, gain) * R
            state[_LEARNED] += 1.0
        else:
            state[_REJECTED] += 1.0
    state[_THETA] = theta
    state[_P] = (0.5 * (P + P.T)).ravel()
    state[_SUMS] = 0.0
    state[_COUNT] = 0.0
    state[_OK] = 1.0
    return state


def calibration_parameters(state) -> list:
    """[b_g, D, sigma(b_g), sigma(D), learned batches, rejected batches] of a calibration state."""
    P = np.asarray(state)[_P].reshape(2, 2)
    return [*state[_THETA], math.sqrt(P[0, 0]), math.sqrt(P[1, 1]), state[_LEARNED], state[_REJECTED]]


PARAMETERS_LAYOUT = (("estimate", 2), ("std", 2), ("batches", 2))
"""YawRateCalibration's ``parameters`` output (calibration_parameters), in order: (name, size)."""
CALIBRATED_LAYOUT = (("gyro", 1), ("odometry", 4))
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
        output_ports:
        - calibrated
        - bias
        - parameters

    - gyro: the checked gyro sample [omega] (rad/s); odometry: the nominal S(10) [^O v_t, ^O omega, v_R,
      v_L]; C1: the C1 in force; inertial_fault, encoder_fault: 1 when this sample's reading was replaced
      (its batch is not learned from).
    - calibrated (direct feedthrough, theta from the state), in CALIBRATED_LAYOUT's order: gyro
      [omega - b_g]; odometry, calibrated_odometry. One vector, one Python call per sample; the
      navigation diagram slices it with a Demultiplexer (diagrams/split.py).
    - bias: [b_g] (rad/s, state).
    - parameters: calibration_parameters (state).

    Update every T_N: yaw_calibration_step (the Kalman update at each batch's end); at a batch's end the
    update also stores the new state's bias and calibration_parameters, which the outputs hold (no Python
    call; theta, P and the batch counts change only there).

    Args:
        params: YawCalibrationParameters. track_width: the nominal track (m). T_N, T_C: periods (s).
    """

    def __init__(self, params: YawCalibrationParameters, track_width: float, T_N: float, T_C: float):
        super().__init__()
        self._p, self._b, self._T_N = params, track_width, T_N
        self._n = int(round(T_C / T_N))
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._faults = [self.DeclareVectorInputPort(name, 1) for name in ("inertial_fault", "encoder_fault")]
        state0 = yaw_calibration_initial_state(params)
        self._state = self.DeclareDiscreteState(state0)
        parameters0 = calibration_parameters(state0)
        self._bias = self.DeclareDiscreteState(np.array(parameters0[0:1], float))
        self._parameters = self.DeclareDiscreteState(np.array(parameters0, float))
        self.DeclareVectorOutputPort(
            "calibrated",
            5,
            self._calc_calibrated,
            prerequisites_of_calc={self.xd_ticket(), self._gyro.ticket(), self._odo.ticket()},
        )
        self.DeclareStateOutputPort("bias", self._bias)
        self.DeclareStateOutputPort("parameters", self._parameters)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_calibrated(self, context, output):
        theta = context.get_discrete_state(self._state).get_value()[_THETA].tolist()
        gyro = calibrated_gyro(float(self._gyro.Eval(context)[0]), theta, self._p)
        output.SetFromVector(
            [gyro, *calibrated_odometry(self._odo.Eval(context).tolist(), theta, self._b, self._p)]
        )

    def _update(self, context, discrete_state):
        inertial, encoder = self._faults
        fault = inertial.Eval(context).tolist()[0] > 0.5 or encoder.Eval(context).tolist()[0] > 0.5
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
        )
        discrete_state.set_value(self._state, state)
        if state[_COUNT] == 0.0:  # a batch ended (or calibration is off): theta, P and the counts moved
            parameters = calibration_parameters(state)
            discrete_state.set_value(self._bias, parameters[0:1])
            discrete_state.set_value(self._parameters, parameters)
