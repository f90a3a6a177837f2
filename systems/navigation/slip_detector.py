"""Tangential slip detector S(11) of Seyr & Jakubek §IV-C: batch of T_C/T_N samples.

S(11) compares, over one batch and after a reset at the batch start, the odometric speed change with the
speed change integrated from the mean tangential acceleration ("discrete integration of the arithmetic
mean of the tangential accelerations"):

    dv_K = (T_N/T_C) sum_{k in batch} (^O v_t,k - ^O v_t,K-1 - sum_{j<=k in batch} (a_t1,j + a_t2,j) T_N/2)

where ^O v_t,K-1 is the odometric speed at the last sample of the previous batch. We read the printed
acceleration term as this running integral (the printed single-sample term would not be an integration).
``running_integral=False`` (``mixing.delta_v_running_integral``, paper mode) computes S(11) exactly as
printed, with the single sample's term (a_t1,k + a_t2,k) T_N/2:

    dv_K = (T_N/T_C) sum_{k in batch} (^O v_t,k - ^O v_t,K-1 - (a_t1,k + a_t2,k) T_N/2).

A trend of wheel speed against body speed is detected, not a stationary slip (§IV-C).

Samples that S(11) cannot use (health.slip_detector_blind) are left out:
dv_K is the sum over the samples the batch could use divided by their number (T_N/T_C of the sum when
all could), and NaN when none could. NaN is "no evidence": the C1 mixer holds C1 rather than read a
blind batch as "no slip" (MixerC1, mixing.mixer_c1_step).
"""

import numpy as np
from pydrake.systems.framework import LeafSystem


def slip_detector_step(
    state,
    odometric_v_t: float,
    accelerometers,
    T_N: float,
    running_integral: bool = True,
    excluded: bool = False,
):
    """Accumulate one sample. state = [sum, integrated speed change, ^O v_t,K-1, samples excluded];
    returns (state', sum).

    ``running_integral``: the inertial speed change integrated since the batch start (default); False:
    only this sample's (a_t1,k + a_t2,k) T_N/2, S(11) as printed. ``excluded``: a sensor channel of this
    sample failed its check (systems/health/): the sample adds nothing to the sum and is counted
    as excluded, so C1 S(12) learns nothing from it (its replaced acceleration still enters the
    integral)."""
    total, integral, v_ref, left_out = state
    integral = (integral if running_integral else 0.0) + 0.5 * (accelerometers[0] + accelerometers[2]) * T_N
    if excluded:
        left_out = left_out + 1.0
    else:
        total = total + (odometric_v_t - v_ref - integral)
    return [total, integral, v_ref, left_out], total


def slip_detector_delta_v(total: float, left_out: float, batch_length: int) -> float:
    """dv_K: the batch's sum divided by the number of samples it used, batch_length - left_out
    (batch_length when none was excluded: S(11)); NaN when every sample was excluded (no evidence)."""
    used = batch_length - left_out
    return total / used if used > 0.0 else float("nan")


def slip_detector_batch_end(
    state, odometric_v_t: float, batch_length: int, excluded: bool = False, running_integral: bool = True
):
    """(dv_K of the batch in ``state`` (slip_detector_delta_v), reset state [0, 0, v_ref, 0]).

    The next batch's reference v_ref is ^O v_t,K, the batch's last sample; when that sample was
    ``excluded`` (a stuck encoder's restored travel, a held odometry) the last reference carried by the
    inertial speed change over the batch instead (v_ref + integral; the reference as it was with S(11) as
    printed, whose integral is one sample's)."""
    reference = odometric_v_t
    if excluded:
        reference = state[2] + state[1] if running_integral else state[2]
    return slip_detector_delta_v(state[0], state[3], batch_length), [0.0, 0.0, reference, 0.0]


class TangentialSlipDetector(LeafSystem):
    """S(11): mean odometric-minus-inertial speed change over each batch of T_C/T_N samples.

    .. pydrake_system::

        name: TangentialSlipDetector
        input_ports:
        - odometry
        - accelerometers
        - sensor_fault
        output_ports:
        - delta_v

    - odometry: [^O v_t, ^O omega, v_R, v_L] of the current sample.
    - accelerometers: checked [a_t1, a_n1, a_t2, a_n2] of the current sample.
    - sensor_fault: 1 when the current sample cannot be used (health.slip_detector_blind: both
      encoders excluded, one with the gyro, an encoder output the odometry cannot use, or both
      tangential accelerometers; its term is left out).
    - delta_v: dv_K of the batch that ends with the current sample (direct feedthrough). Batches end at
      the control instants t = K*T_C (sample k = K*n, n = T_C/T_N); the MixerC1 block samples this port
      there. Between control instants the port shows the running partial mean. NaN when every sample of
      the batch was excluded (slip_detector_delta_v).

    Update every T_N: accumulate; at control instants reset with ^O v_t,K as the new reference. The
    update computes the sample's step itself, and delta_v only when read (at T_C): no Python call per
    sample for an output.

    Args:
        T_N, T_C: periods (s); batch_length n = T_C/T_N.
        initial_speed: ^O v_t,-1, the reference speed of the first batch (m/s).
        running_integral: see slip_detector_step (False: S(11) as printed).
    """

    def __init__(self, T_N: float, T_C: float, initial_speed: float = 0.0, running_integral: bool = True):
        super().__init__()
        self._T_N, self._running = T_N, running_integral
        self._n = int(round(T_C / T_N))
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._acc = self.DeclareVectorInputPort("accelerometers", 4)
        self._fault = self.DeclareVectorInputPort("sensor_fault", 1)
        self._state = self.DeclareDiscreteState(np.array([0.0, 0.0, float(initial_speed), 0.0]))
        prereq = {self.xd_ticket(), self._odo.ticket(), self._acc.ticket(), self._fault.ticket()}
        # No per-sample output calc: the update accumulates itself, and delta_v is computed only when read
        # (the MixerC1 samples it at the control instants).
        self.DeclareVectorOutputPort("delta_v", 1, self._calc_delta_v, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _step(self, context, state: list):
        """(v_t of the odometry, whether the sample is excluded, slip_detector_step of ``state`` and the
        current inputs)."""
        v_t = self._odo.Eval(context).tolist()[0]
        fault = self._fault.Eval(context).tolist()[0] > 0.5
        return (
            v_t,
            fault,
            slip_detector_step(state, v_t, self._acc.Eval(context).tolist(), self._T_N, self._running, fault),
        )

    def _calc_delta_v(self, context, output):
        _, _, (new, _) = self._step(context, context.get_discrete_state(self._state).get_value().tolist())
        output.SetFromVector([slip_detector_delta_v(new[0], new[3], self._n)])

    def _update(self, context, discrete_state):
        state = discrete_state.get_mutable_value(self._state)  # read and written in place
        v_t, excluded, (new, _) = self._step(context, state.tolist())
        if int(round(context.get_time() / self._T_N)) % self._n == 0:
            _, new = slip_detector_batch_end(new, v_t, self._n, excluded, self._running)
        state[:] = new
