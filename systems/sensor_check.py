"""Guard of the inertial sensor samples: NaN/inf never reach the filters (detect, hold, flag)."""

import numpy as np
from pydrake.systems.framework import LeafSystem


def check_sample(sample, last_valid):
    """(sample with every non-finite channel replaced by its last valid value, fault flag 0/1)."""
    sample = np.asarray(sample, float)
    bad = ~np.isfinite(sample)
    if not bad.any():
        return sample, 0.0
    return np.where(bad, last_valid, sample), 1.0


class InertialSampleCheck(LeafSystem):
    """Replaces NaN/inf accelerometer or gyro channels by the channel's last valid value and flags them.

    .. pydrake_system::

        name: InertialSampleCheck
        input_ports:
        - accelerometers
        - gyro
        output_ports:
        - accelerometers
        - gyro
        - fault
        - fault_count

    - accelerometers (4), gyro (1): raw samples in; checked samples out (direct feedthrough).
    - fault: 1 when any channel of the current sample was not finite, else 0.
    - fault_count: number of faulty samples so far.

    Update every T_N: remember the checked sample (the last valid value of each channel) and count faults.

    Args:
        T_N: navigation period (s).
        initial: the value held for a channel that is invalid from the start ([a_t1..a_n2, omega]).
    """

    def __init__(self, T_N: float, initial=None):
        super().__init__()
        self._accel_in = self.DeclareVectorInputPort("accelerometers", 4)
        self._gyro_in = self.DeclareVectorInputPort("gyro", 1)
        self._last = self.DeclareDiscreteState(np.zeros(5) if initial is None else np.asarray(initial))
        self._count = self.DeclareDiscreteState(1)
        inputs = {self.xd_ticket(), self._accel_in.ticket(), self._gyro_in.ticket()}
        self._checked = self.DeclareVectorOutputPort(
            "checked", 6, self._calc_checked, prerequisites_of_calc=inputs
        )
        self.DeclareVectorOutputPort(
            "accelerometers",
            4,
            lambda c, o: o.SetFromVector(self._checked.Eval(c)[0:4]),
            prerequisites_of_calc=inputs,
        )
        self.DeclareVectorOutputPort(
            "gyro",
            1,
            lambda c, o: o.SetFromVector(self._checked.Eval(c)[4:5]),
            prerequisites_of_calc=inputs,
        )
        self.DeclareVectorOutputPort(
            "fault",
            1,
            lambda c, o: o.SetFromVector(self._checked.Eval(c)[5:6]),
            prerequisites_of_calc=inputs,
        )
        self.DeclareStateOutputPort("fault_count", self._count)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc_checked(self, context, output):
        raw = np.concatenate([self._accel_in.Eval(context), self._gyro_in.Eval(context)])
        sample, fault = check_sample(raw, context.get_discrete_state(self._last).get_value())
        output.SetFromVector(np.append(sample, fault))

    def _update(self, context, discrete_state):
        checked = self._checked.Eval(context)
        discrete_state.set_value(self._last, checked[0:5])
        count = context.get_discrete_state(self._count).get_value()[0]
        discrete_state.set_value(self._count, [count + checked[5]])
