"""Inertial extended Kalman filter of Seyr & Jakubek §IV-A: S(2)-S(9); the gain S(7) runs at T_C.

State x = [v_t, v_n, omega, a_t, a_n] (EkfState), measurement y = [omega_gyro, mean a_t, mean a_n] S(3).
The filter's state is overwritten after every sample by the mixed estimate (Fig. 3), so the block takes
the mixer's output as the next state instead of its own update.

The velocities are not measured (S(3)); their variance therefore grows, and under sustained rotation it
grows geometrically, because the forward-Euler rotation of S(2) has |eigenvalue| sqrt(1 + (omega T_N)^2).
The measured block (omega, a_t, a_n) and the gain S(7) stay at their steady values (tests/test_navigation).
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import LeafSystem

EkfState = namedview("EkfState", ["v_t", "v_n", "omega", "a_t", "a_n"])

MEASUREMENT_MATRIX = np.array(
    [[0.0, 0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0]]
)
"""C of S(4): the measurement prediction is linear, y_hat = [omega, a_t, a_n]."""


@dc.dataclass
class EkfParameters:
    """Noise covariances of the EKF (diagonals).

    Defaults, from the sensor models of systems/sensors.py:
    - R: gyro 0.014^2 (ADXRS300 rms noise); each acceleration channel is the mean of two sensors,
      (0.062^2 + 0.3^2)/2 = 0.047: white noise plus the commotion at ~1 m/s, halved by averaging S(3).
    - Q: "as small as possible but large enough to ensure convergence" (§IV-A): velocities 1e-8 (they
      are integrated, not driven), yaw-rate change (20 rad/s^2 * T_N)^2 = 1.6e-3, acceleration change
      (100 m/s^3 * T_N)^2 = 0.04.
    - P0: initial covariance.
    """

    Q: list[float] = dc.field(default_factory=lambda: [1e-8, 1e-8, 1.6e-3, 0.04, 0.04])
    R: list[float] = dc.field(default_factory=lambda: [0.014**2, 0.047, 0.047])
    P0: list[float] = dc.field(default_factory=lambda: [1e-4, 1e-4, 1e-3, 1.0, 1.0])

    def __post_init__(self):
        for name, size in (("Q", 5), ("R", 3), ("P0", 5)):
            values = getattr(self, name)
            if len(values) != size:
                raise ValueError(f"ekf.{name} must list {size} diagonal entries, got {len(values)}")
            for i, v in enumerate(values):
                if not (math.isfinite(v) and v > 0.0):
                    raise ValueError(f"ekf.{name}[{i}]={v!r} is out of range: allowed (0, inf)")

    def matrices(self):
        return np.diag(self.Q), np.diag(self.R), np.diag(self.P0)


def ekf_measurement(accelerometers, gyro) -> np.ndarray:
    """S(3): y = [omega, (a_t1 + a_t2)/2, (a_n1 + a_n2)/2]."""
    a = accelerometers
    return np.array([gyro[0], 0.5 * (a[0] + a[2]), 0.5 * (a[1] + a[3])])


def ekf_predict(x, T_N: float) -> np.ndarray:
    """S(2): v_t += (a_t + v_n*omega)*T_N, v_n += (a_n - v_t*omega)*T_N; omega, a_t, a_n constant."""
    v_t, v_n, omega, a_t, a_n = x
    return np.array([v_t + (a_t + v_n * omega) * T_N, v_n + (a_n - v_t * omega) * T_N, omega, a_t, a_n])


def ekf_jacobian(x, T_N: float) -> np.ndarray:
    """S(5): G = d(S(2))/dx at x."""
    v_t, v_n, omega, _, _ = x
    G = np.eye(5)
    G[0, 1], G[0, 2], G[0, 3] = omega * T_N, v_n * T_N, T_N
    G[1, 0], G[1, 2], G[1, 4] = -omega * T_N, -v_t * T_N, T_N
    return G


def ekf_prior_covariance(P, x, Q, T_N: float) -> np.ndarray:
    """S(6): P_{k|k-1} = G P G^T + Q."""
    G = ekf_jacobian(x, T_N)
    return G @ P @ G.T + Q


def ekf_gain(P_prior, R) -> np.ndarray:
    """S(7): L = P C^T (C P C^T + R)^-1 (5 x 3)."""
    C = MEASUREMENT_MATRIX
    S = C @ P_prior @ C.T + R
    return np.linalg.solve(S, C @ P_prior).T


def ekf_update(x_prior, L, y) -> np.ndarray:
    """S(8): x = x_{k|k-1} + L (y - C x_{k|k-1}); C selects [omega, a_t, a_n] = x[2:5]."""
    return x_prior + L @ (y - x_prior[2:5])


def ekf_joseph(P_prior, L, R) -> np.ndarray:
    """S(9): P = (I - L C) P_{k|k-1} (I - L C)^T + L R L^T (Joseph form, stays symmetric PSD)."""
    A = np.eye(5)
    A[:, 2:5] -= L  # I - L C, C = [0 | I_3]
    P = A @ P_prior @ A.T + L @ R @ L.T
    return 0.5 * (P + P.T)


class InertialEkf(LeafSystem):
    """Prediction S(2), Jacobian S(5), covariance S(6), update S(8) and Joseph covariance S(9) at T_N.

    .. pydrake_system::

        name: InertialEkf
        input_ports:
        - accelerometers
        - gyro
        - kalman_gain
        - mixed_estimate
        output_ports:
        - inertial_estimate
        - prior_covariance
        - estimate
        - covariance

    - accelerometers [a_t1, a_n1, a_t2, a_n2], gyro [omega]: the (checked) sensor sample of this step.
    - kalman_gain: L_K (5 x 3, row-major) from the KalmanGain block, S(7).
    - mixed_estimate: the mixer's S(15)-(17) estimate of this step; it becomes the filter state (Fig. 3).
    - inertial_estimate: ^I x_k = S(8) applied to the prediction S(2) of the state (direct feedthrough of
      the sensor sample and the gain).
    - prior_covariance: P_{k|k-1}, S(6), from the state (for the gain block).
    - estimate: the state x_{k-1} (the previous mixed estimate; the mixer reads v_n,k-1 from it for S(17)).
    - covariance: P_{k-1}.

    Update every T_N (offset 0): x <- mixed_estimate, P <- S(9)(P_{k|k-1}, L_K).

    Args:
        params: EkfParameters.
        T_N: navigation period (s).
        x0: initial state [v_t, v_n, omega, a_t, a_n].
    """

    def __init__(self, params: EkfParameters, T_N: float, x0=None):
        super().__init__()
        self._Q, self._R, P0 = params.matrices()
        self._T_N = T_N
        x0 = np.zeros(5) if x0 is None else np.asarray(x0, float)
        self._accel_port = self.DeclareVectorInputPort("accelerometers", 4)
        self._gyro_port = self.DeclareVectorInputPort("gyro", 1)
        self._gain_port = self.DeclareVectorInputPort("kalman_gain", 15)
        self._mixed_port = self.DeclareVectorInputPort("mixed_estimate", 5)
        self._x = self.DeclareDiscreteState(x0)
        self._P = self.DeclareDiscreteState(P0.ravel())
        self._inertial_port = self.DeclareVectorOutputPort(
            "inertial_estimate",
            5,
            self._calc_inertial,
            prerequisites_of_calc={
                self.xd_ticket(),
                self._accel_port.ticket(),
                self._gyro_port.ticket(),
                self._gain_port.ticket(),
            },
        )
        self._prior_port = self.DeclareVectorOutputPort(
            "prior_covariance", 25, self._calc_prior, prerequisites_of_calc={self.xd_ticket()}
        )
        self.DeclareStateOutputPort("estimate", self._x)
        self.DeclareStateOutputPort("covariance", self._P)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_inertial(self, context, output):
        x = context.get_discrete_state(self._x).get_value()
        y = ekf_measurement(self._accel_port.Eval(context), self._gyro_port.Eval(context))
        L = self._gain_port.Eval(context).reshape(5, 3)
        output.SetFromVector(ekf_update(ekf_predict(x, self._T_N), L, y))

    def _calc_prior(self, context, output):
        x = context.get_discrete_state(self._x).get_value()
        P = context.get_discrete_state(self._P).get_value().reshape(5, 5)
        output.SetFromVector(ekf_prior_covariance(P, x, self._Q, self._T_N).ravel())

    def _update(self, context, discrete_state):
        P_prior = self._prior_port.Eval(context).reshape(5, 5)
        L = self._gain_port.Eval(context).reshape(5, 3)
        discrete_state.set_value(self._x, self._mixed_port.Eval(context))
        discrete_state.set_value(self._P, ekf_joseph(P_prior, L, self._R).ravel())


class KalmanGain(LeafSystem):
    """Kalman gain S(7), L_K = P C^T (C P C^T + R)^-1, recomputed every T_C from the EKF's P_{k|k-1}.

    .. pydrake_system::

        name: KalmanGain
        input_ports:
        - prior_covariance
        output_ports:
        - kalman_gain

    The gain computed at t_K from P_{K|K-1} is used by the EKF from the next sample on (Drake reads
    pre-update values at t_K), i.e. for samples Kn+1 ... (K+1)n.

    Args:
        params: EkfParameters (R).
        T_C: control period (s).
        P_prior0: prior covariance the initial gain is computed from.
    """

    def __init__(self, params: EkfParameters, T_C: float, P_prior0):
        super().__init__()
        _, self._R, _ = params.matrices()
        self._prior_port = self.DeclareVectorInputPort("prior_covariance", 25)
        L0 = ekf_gain(np.asarray(P_prior0).reshape(5, 5), self._R)
        self._L = self.DeclareDiscreteState(L0.ravel())
        self.DeclareStateOutputPort("kalman_gain", self._L)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

    def _update(self, context, discrete_state):
        P_prior = self._prior_port.Eval(context).reshape(5, 5)
        discrete_state.set_value(self._L, ekf_gain(P_prior, self._R).ravel())
