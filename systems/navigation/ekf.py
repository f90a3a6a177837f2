"""Inertial extended Kalman filter of Seyr & Jakubek §IV-A: S(2)-S(9); the gain S(7) runs at T_C.

State x = [v_t, v_n, omega, a_t, a_n] (EkfState), measurement y = [omega_gyro, mean a_t, mean a_n] S(3).
The filter's state is overwritten after every sample by the mixed estimate (Fig. 3), so the block takes
the mixer's output as the next state instead of its own update.

The velocities are not measured by S(3). Left to S(6) and S(9) alone their variance grows without bound,
geometrically under sustained rotation (the forward-Euler rotation of S(2) has |eigenvalue|
sqrt(1 + (omega T_N)^2): 1e300 after ~860 s of spinning at 20 rad/s, then NaN). But the filter continues
from the mixed estimate (Fig. 3), and the mixing laws are linear updates of ^I v_t and ^I v_n by quantities
from outside the filter: S(15) v_t = ^I v_t + C1 (^O v_t - ^I v_t) and S(17) v_n = ^I v_n + w_n (m - ^I v_n),
Kalman updates with the fixed gains C1 and w_n by the pseudo-measurements ^O v_t (odometry) and m (the
tyre model; zero in the paper). ekf_mixing_covariance carries them into P (Joseph form, valid for any
gain), applied to the part of the velocities' covariance that the measured states do not explain (the
Schur complement), which is the part that grows; the velocity-vs-measured cross-covariances, the only
part of P the gain S(7) reads, stay the inertial filter's, so S(7)-(8) and every estimate are unchanged.
ekf_bound_velocity_variance caps what may still grow (a long slide at the friction limit with the wheels
slipping, C1 = w_n = 0) at a documented limit.
The measured block (omega, a_t, a_n) and the gain S(7) stay at their steady values (tests/test_navigation).
"""

import dataclasses as dc
import functools
import math

import numpy as np
from pydrake.common.containers import namedview
from pydrake.systems.framework import LeafSystem
from slipnav.systems.compiled import ENABLED, compiled, jitable
from slipnav.systems.ranges import require_in

EkfState = namedview("EkfState", ["v_t", "v_n", "omega", "a_t", "a_n"])

MEASUREMENT_MATRIX = np.array(
    [[0.0, 0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0]]
)
"""C of S(4): the measurement prediction is linear, y_hat = [omega, a_t, a_n]."""
IDENTITY_5 = np.eye(5)
IDENTITY_3 = np.eye(3)
"""The identities the filter's matrices start from (copied where written)."""


@dc.dataclass
class EkfParameters:
    """Noise covariances of the EKF (diagonals).

    Defaults, from the sensor models of systems/robot/sensors.py:
    - R: gyro 0.014^2 (ADXRS300 rms noise); each acceleration channel is the mean of two sensors,
      (0.062^2 + 0.3^2)/2 = 0.047: white noise plus the commotion at ~1 m/s, halved by averaging S(3).
    - Q: "as small as possible but large enough to ensure convergence" (§IV-A): velocities 1e-8 (they
      are integrated, not driven), yaw-rate change (20 rad/s^2 * T_N)^2 = 1.6e-3, acceleration change
      (100 m/s^3 * T_N)^2 = 0.04.
    - P0: initial covariance.
    - R_mixing: variances of the mixer's pseudo-measurements of v_t and v_n (ekf_mixing_covariance):
      odometric v_t, the two wheels' 2 ms speeds quantised in r 2 pi / (6144 T_N) = 7.7 mm/s steps,
      (7.7e-3)^2 / 6 / 2 = 5e-6 (Tinyphoon; Kurt3D's 61 mm/s steps: 3e-4); the tyre model's side-slip
      velocity, 1e-4 ((1 cm/s)^2, the side slip of a hard turn held to the tyre curve, MixingParameters).
    - velocity_variance_limit: largest variance of v_t and v_n given the measured states (m^2/s^2)
      (ekf_bound_velocity_variance): 1, a 1 m/s standard deviation, beyond which a velocity estimate
      carries no information; reached only when neither odometry nor the tyre model has weighed in for a
      long time (minutes of sliding at the friction limit with the wheels slipping).
    """

    Q: list[float] = dc.field(default_factory=lambda: [1e-8, 1e-8, 1.6e-3, 0.04, 0.04])
    R: list[float] = dc.field(default_factory=lambda: [0.014**2, 0.047, 0.047])
    P0: list[float] = dc.field(default_factory=lambda: [1e-4, 1e-4, 1e-3, 1.0, 1.0])
    R_mixing: list[float] = dc.field(default_factory=lambda: [5e-6, 1e-4])
    velocity_variance_limit: float = 1.0

    def __post_init__(self):
        require_in("ekf.velocity_variance_limit", self.velocity_variance_limit, "(0, inf) m^2/s^2")
        for name, size in (("Q", 5), ("R", 3), ("P0", 5), ("R_mixing", 2)):
            values = getattr(self, name)
            if len(values) != size:
                raise ValueError(f"ekf.{name} must list {size} diagonal entries, got {len(values)}")
            for i, v in enumerate(values):
                require_in(f"ekf.{name}[{i}]", v, "(0, inf)")

    def matrices(self):
        return np.diag(self.Q), np.diag(self.R), np.diag(self.P0)


def ekf_measurement(accelerometers, gyro) -> np.ndarray:
    """S(3): y = [omega, (a_t1 + a_t2)/2, (a_n1 + a_n2)/2]."""
    a = accelerometers
    return np.array([gyro[0], 0.5 * (a[0] + a[2]), 0.5 * (a[1] + a[3])])


@jitable
def ekf_predict(x, T_N: float) -> np.ndarray:
    """S(2): v_t += (a_t + v_n*omega)*T_N, v_n += (a_n - v_t*omega)*T_N; omega, a_t, a_n constant."""
    v_t, v_n, omega, a_t, a_n = x
    return np.array([v_t + (a_t + v_n * omega) * T_N, v_n + (a_n - v_t * omega) * T_N, omega, a_t, a_n])


@jitable
def ekf_jacobian(x, T_N: float) -> np.ndarray:
    """S(5): G = d(S(2))/dx at x."""
    v_t, v_n, omega, _, _ = x
    G = IDENTITY_5.copy()
    G[0, 1], G[0, 2], G[0, 3] = omega * T_N, v_n * T_N, T_N
    G[1, 0], G[1, 2], G[1, 4] = -omega * T_N, -v_t * T_N, T_N
    return G


@compiled
def ekf_prior_covariance(P, x, Q, T_N: float) -> np.ndarray:
    """S(6): P_{k|k-1} = G P G^T + Q."""
    G = ekf_jacobian(x, T_N)
    return G @ P @ G.T + Q


def ekf_gain(P_prior, R) -> np.ndarray:
    """S(7): L = P C^T (C P C^T + R)^-1 (5 x 3)."""
    C = MEASUREMENT_MATRIX
    S = C @ P_prior @ C.T + R
    return np.linalg.solve(S, C @ P_prior).T


@jitable
def ekf_update(x_prior, L, y) -> np.ndarray:
    """S(8): x = x_{k|k-1} + L (y - C x_{k|k-1}); C selects [omega, a_t, a_n] = x[2:5]."""
    return x_prior + L @ (y - x_prior[2:5])


@jitable
def ekf_joseph(P_prior, L, R) -> np.ndarray:
    """S(9): P = (I - L C) P_{k|k-1} (I - L C)^T + L R L^T (Joseph form, stays symmetric PSD)."""
    A, noise = joseph_factors(L, R)
    return joseph_form(P_prior, A, noise)


@compiled
def joseph_factors(L, R) -> tuple:
    """(I - L C, L R L^T): S(9)'s factors of the gain L, which hold while L does (a T_C period)."""
    A = IDENTITY_5.copy()
    A[:, 2:5] -= L  # I - L C, C = [0 | I_3]
    return A, L @ R @ L.T


@compiled
def joseph_form(P_prior, A, noise) -> np.ndarray:
    """S(9) from joseph_factors' (A, noise): A P_{k|k-1} A^T + noise, symmetrised."""
    P = A @ P_prior @ A.T + noise
    return 0.5 * (P + P.T)


def measured_inverse(P) -> np.ndarray:
    """P_mm^-1 (m: omega, a_t, a_n) of the covariance P, as numpy's inv computes it (LAPACK gesv on the
    identity; numba's inv rounds otherwise), remembered by P_mm's value (read-only). S(6)-(9) never feed
    the velocities into P_mm, so it runs through the same values on every run with the same EkfParameters
    and settles on a fixed point within some 50 samples: the inverse is solved only while it moves."""
    return _inverse_of(P[2:5, 2:5].tobytes())


@functools.lru_cache(maxsize=256)
def _inverse_of(measured_block: bytes) -> np.ndarray:
    inverse = np.linalg.solve(np.frombuffer(measured_block).reshape(3, 3), IDENTITY_3)
    inverse.flags.writeable = False
    return inverse


@jitable
def _velocity_split(P, measured_inverse) -> tuple:
    """(E, S): the velocity block P_vv = E + S (v: v_t, v_n) split into the part explained by the measured
    states' errors, E = B P_mm B^T with B = P_vm P_mm^-1, and the Schur complement S, the velocities'
    covariance given the measured states; each 2 x 2 block element by element, (tt, tn, nt, nn).
    ``measured_inverse``: P_mm^-1 (measured_inverse)."""
    P_vm = P[0:2, 2:5].copy()  # contiguous, as numba's @ prefers
    E = P_vm @ measured_inverse @ P_vm.T
    explained = (float(E[0, 0]), float(E[0, 1]), float(E[1, 0]), float(E[1, 1]))
    S = (
        float(P[0, 0]) - explained[0],
        float(P[0, 1]) - explained[1],
        float(P[1, 0]) - explained[2],
        float(P[1, 1]) - explained[3],
    )
    return explained, S


@jitable
def _with_velocity_block(P, explained, S) -> np.ndarray:
    """P with the velocity block E + S (_velocity_split's order), symmetrised."""
    P = P.copy()
    tt, tn, nt, nn = (explained[0] + S[0], explained[1] + S[1], explained[2] + S[2], explained[3] + S[3])
    P[0, 0] = 0.5 * (tt + tt)
    P[0, 1] = 0.5 * (tn + nt)
    P[1, 0] = 0.5 * (nt + tn)
    P[1, 1] = 0.5 * (nn + nn)
    return P


def ekf_mixing_covariance(P, gain, R_mixing) -> np.ndarray:
    """The mixing S(15), S(17) as pseudo-measurement updates of P (after S(9)).

    S(15) is v_t = ^I v_t + C1 (^O v_t - ^I v_t): an update of v_t by the measurement ^O v_t (variance
    R_t = R_mixing[0]) with the fixed gain C1. S(17) is, to first order in T_N (v_n,k-1 = ^I v_n),
    v_n = ^I v_n + w_n (m - ^I v_n), w_n = 1 - C2 q2 - (1 - C2) q_I (mixing.mixing_gain): an update by the
    tyre model's m (R_n = R_mixing[1]; m = 0 in the paper) with the gain w_n. With W = diag(C1, w_n), the
    Joseph form (valid for any gain) of these updates is applied to the velocities' covariance given the
    measured states, S = P_vv - P_vm P_mm^-1 P_mv (_velocity_split):

        S <- (I - W) S (I - W) + W diag(R_t, R_n) W,    P_vv = P_vm P_mm^-1 P_mv + S,

    P_vm and P_mm untouched: they are what S(7) reads (L = P C^T (C P C^T + R)^-1 takes P_vm and P_mm
    only), the inertial filter's integration of the measured accelerations, and S(6)-(9) never feed P_vv
    back into them, so the filter's gains and estimates stay exactly the paper's. P stays symmetric
    positive definite (S is positive definite, and so is P_mm). Without rotation and cross-covariance,
    P_tt <- (1 - C1)^2 P_tt + C1^2 R_t.

    Args:
        P: 5 x 5 covariance after S(9). gain: [C1, w_n]. R_mixing: [R_t, R_n].
    """
    explained, S = _velocity_split(P, measured_inverse(P))
    return _with_velocity_block(P, explained, _mixing_update(S, gain, R_mixing))


@jitable
def _mixing_update(S, gain, R_mixing) -> tuple:
    """(I - W) S (I - W) + W diag(R_mixing) W, W = diag(gain) (2 x 2, _velocity_split's order)."""
    a_t, a_n = 1.0 - gain[0], 1.0 - gain[1]
    cross = a_t * a_n * S[1]
    return (
        a_t * a_t * S[0] + gain[0] * gain[0] * R_mixing[0],
        cross,
        cross,
        a_n * a_n * S[3] + gain[1] * gain[1] * R_mixing[1],
    )


@jitable
def _bound(S, limit: float) -> tuple:
    """D S D, D = diag(min(1, sqrt(limit / S_ii))) (2 x 2, _velocity_split's order)."""
    if S[0] <= limit and S[3] <= limit:
        return S
    d_t, d_n = min(1.0, math.sqrt(limit / S[0])), min(1.0, math.sqrt(limit / S[3]))
    return (S[0] * (d_t * d_t), S[1] * (d_t * d_n), S[2] * (d_n * d_t), S[3] * (d_n * d_n))


def ekf_bound_velocity_variance(P, limit: float) -> np.ndarray:
    """Caps the variances of v_t and v_n given the measured states (S of ekf_mixing_covariance) at
    ``limit``: S <- D S D with D = diag(min(1, sqrt(limit / S_ii))), a congruence that keeps S positive
    definite and the correlation of v_t and v_n as it was (EkfParameters.velocity_variance_limit); P_vm
    and P_mm, and so the gain S(7), untouched."""
    explained, S = _velocity_split(P, measured_inverse(P))
    return _with_velocity_block(P, explained, _bound(S, limit))


def ekf_covariance_update(P_prior, L, R, gain, params: EkfParameters, factors=None) -> np.ndarray:
    """P_k: S(9) (R: the 3 x 3 measurement covariance of ``params``), then the mixing S(15), S(17)
    (ekf_mixing_covariance), then the velocity limit (ekf_bound_velocity_variance). ``gain``: [C1, w_n]
    of this sample's mixing (mixing.mixing_gain); ``factors``: joseph_factors(L, R) when the caller
    holds them (None: computed here)."""
    R_mixing = (float(params.R_mixing[0]), float(params.R_mixing[1]))
    gain = (float(gain[0]), float(gain[1]))
    limit = float(params.velocity_variance_limit)
    if ENABLED and factors is None:  # one compiled call: it solves for P_mm^-1 as cheaply as it looks it up
        return _covariance_update(P_prior, L, R, gain, R_mixing, limit)
    A, noise = joseph_factors(L, R) if factors is None else factors
    if ENABLED:
        return _factored_covariance_update(P_prior, A, noise, gain, R_mixing, limit)
    P = joseph_form(P_prior, A, noise)
    return mixed_covariance(P, measured_inverse(P), gain, R_mixing, limit)


@compiled
def _covariance_update(P_prior, L, R, gain, R_mixing, limit: float) -> np.ndarray:
    """_factored_covariance_update of the gain L itself (joseph_factors inside)."""
    A, noise = joseph_factors(L, R)
    return _factored_covariance_update(P_prior, A, noise, gain, R_mixing, limit)


@compiled
def _factored_covariance_update(P_prior, A, noise, gain, R_mixing, limit: float) -> np.ndarray:
    """ekf_covariance_update with S(9)'s joseph_factors (A, noise) of the gain, P_mm^-1 solved (as
    measured_inverse solves it) rather than looked up: the compiled path's."""
    P = joseph_form(P_prior, A, noise)
    return mixed_covariance(P, np.linalg.solve(P[2:5, 2:5], IDENTITY_3), gain, R_mixing, limit)


@compiled
def mixed_covariance(P, measured_inverse, gain, R_mixing, limit: float) -> np.ndarray:
    """ekf_covariance_update after S(9): the mixing (ekf_mixing_covariance), the velocity limit
    (ekf_bound_velocity_variance, _bound_cross_covariance) on P with P_mm^-1 ``measured_inverse``."""
    explained, S = _velocity_split(P, measured_inverse)
    S = _bound(_mixing_update(S, gain, R_mixing), limit)
    return _with_velocity_block(*_bound_cross_covariance(P, explained, S, limit))


@compiled
def ekf_inertial_estimate(x, L, y, T_N: float) -> np.ndarray:
    """^I x_k = S(8) applied to the prediction S(2) of x: ekf_update(ekf_predict(x, T_N), L, y)."""
    return ekf_update(ekf_predict(x, T_N), L, y)


@jitable
def _bound_cross_covariance(P, explained, S, limit: float):
    """(P, explained, S) with the velocities' cross-covariance with the measured states P_vm scaled by
    c = min_i sqrt((limit - S_ii) / E_ii) where the whole variance E_ii + S_ii (E = P_vm P_mm^-1 P_mv)
    exceeds ``limit``. P_vm grows as S(5)'s rotation when the odometry is not trusted for long in a fast
    spin (C1 = 0: no pseudo-measurement). The Schur complement stays S, so P stays positive definite;
    inactive below the limit (every built-in run: the gains S(7) are the paper's there). The 2 x 2 blocks
    in _velocity_split's order."""
    c = math.inf
    for i in (0, 3):  # tt, nn
        if explained[i] + S[i] > limit and explained[i] > 0.0:
            c = min(c, math.sqrt(max(limit - S[i], 0.0) / explained[i]))
    if c == math.inf:
        return P, explained, S
    P = P.copy()
    P[0:2, 2:5] *= c
    P[2:5, 0:2] *= c
    scale = c * c
    return P, (explained[0] * scale, explained[1] * scale, explained[2] * scale, explained[3] * scale), S


class InertialEkf(LeafSystem):
    """Prediction S(2), Jacobian S(5), covariance S(6), update S(8) and Joseph covariance S(9) at T_N, with
    the mixing S(15), S(17) as pseudo-measurements in P (ekf_mixing_covariance).

    .. pydrake_system::

        name: InertialEkf
        input_ports:
        - accelerometers
        - gyro
        - kalman_gain
        - mixed_estimate
        - mixing_gain
        output_ports:
        - inertial_estimate
        - prior_covariance
        - estimate
        - covariance

    - accelerometers [a_t1, a_n1, a_t2, a_n2], gyro [omega]: the (checked) sensor sample of this step.
    - kalman_gain: L_K (5 x 3, row-major) from the KalmanGain block, S(7).
    - mixed_estimate: the mixer's S(15)-(17) estimate of this step; it becomes the filter state (Fig. 3).
    - mixing_gain: [C1, w_n], the weights of odometry in S(15) and of the tyre model in S(17) this step
      (VelocityMixer); P sees the mixing through them (ekf_mixing_covariance).
    - inertial_estimate: ^I x_k = S(8) applied to the prediction S(2) of the state (direct feedthrough of
      the sensor sample and the gain).
    - prior_covariance: P_{k|k-1}, S(6), of the state (for the gain block; state).
    - estimate: the state x_{k-1} (the previous mixed estimate; the mixer reads v_n,k-1 from it for S(17)).
    - covariance: P_{k-1}.

    Update every T_N (offset 0): x <- mixed_estimate, P <- ekf_covariance_update: S(9)(P_{k|k-1}, L_K),
    then the mixing's pseudo-measurements, then the velocity variance limit; then the next prior
    covariance S(6) of the new x and P, which the update stores (so that reading it costs no Python call).

    Args:
        params: EkfParameters.
        T_N: navigation period (s).
        x0: initial state [v_t, v_n, omega, a_t, a_n].
    """

    def __init__(self, params: EkfParameters, T_N: float, x0=None):
        super().__init__()
        self._Q, self._R, P0 = params.matrices()
        self._params, self._T_N = params, T_N
        x0 = np.zeros(5) if x0 is None else np.asarray(x0, float)
        self._accel_port = self.DeclareVectorInputPort("accelerometers", 4)
        self._gyro_port = self.DeclareVectorInputPort("gyro", 1)
        self._gain_port = self.DeclareVectorInputPort("kalman_gain", 15)
        self._mixed_port = self.DeclareVectorInputPort("mixed_estimate", 5)
        self._mixing_gain_port = self.DeclareVectorInputPort("mixing_gain", 2)
        self._x = self.DeclareDiscreteState(x0)
        self._P = self.DeclareDiscreteState(P0.ravel())
        self._prior = self.DeclareDiscreteState(ekf_prior_covariance(P0, x0, self._Q, T_N).ravel())
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
        self.DeclareStateOutputPort("prior_covariance", self._prior)
        self.DeclareStateOutputPort("estimate", self._x)
        self.DeclareStateOutputPort("covariance", self._P)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_inertial(self, context, output):
        x = context.get_discrete_state(self._x).get_value()
        y = ekf_measurement(self._accel_port.Eval(context).tolist(), self._gyro_port.Eval(context).tolist())
        L = self._gain_port.Eval(context).reshape(5, 3)
        output.SetFromVector(ekf_inertial_estimate(x, L, y, self._T_N))

    def _update(self, context, discrete_state):
        P_prior = discrete_state.get_value(self._prior).reshape(5, 5)
        L = self._gain_port.Eval(context).reshape(5, 3)
        x = self._mixed_port.Eval(context).copy()
        gain = self._mixing_gain_port.Eval(context).tolist()
        P = ekf_covariance_update(P_prior, L, self._R, gain, self._params)
        discrete_state.set_value(self._x, x)
        discrete_state.set_value(self._P, P.ravel())
        discrete_state.set_value(self._prior, ekf_prior_covariance(P, x, self._Q, self._T_N).ravel())


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
