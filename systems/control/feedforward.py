"""Open-loop feed-forward of a pre-planned trajectory's wheel speeds, held at T_C.

This is the stand-in controller of the open-loop scenarios: it plays back the trajectory's rolling
wheel speeds v_R = v + omega*b/2, v_L = v - omega*b/2 (S(10) inverted) without any feedback.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import LeafSystem


class TrajectoryFeedforward(LeafSystem):
    """Plays back a table of wheel-speed commands and reference poses, one row per control sample K.

    .. pydrake_system::

        name: TrajectoryFeedforward
        output_ports:
        - wheel_speed_command
        - reference_pose

    - wheel_speed_command: [v_R, v_L] (m/s) of sample K = round((t - start_time) / T_C), held until
      t_{K+1}; after the last row the last row is held.
    - reference_pose: [x, y, phi] of the trajectory at sample K.

    Args:
        T_C: control period (s).
        wheel_speeds: (N, 2) array of [v_R, v_L].
        reference_poses: (N, 3) array of [x, y, phi].
        start_time: time of row 0 (s, a multiple of T_C); until then row 0 is held (the standstill).
    """

    def __init__(self, T_C: float, wheel_speeds, reference_poses, start_time: float = 0.0):
        super().__init__()
        table = np.hstack([np.asarray(wheel_speeds, float), np.asarray(reference_poses, float)])
        if table.ndim != 2 or table.shape[1] != 5 or len(table) == 0:
            raise ValueError("wheel_speeds must be (N, 2) and reference_poses (N, 3) with N >= 1")
        self._table = table
        self._T_C, self._start = T_C, start_time
        self._command = self.DeclareDiscreteState(table[0, 0:2])
        self._pose = self.DeclareDiscreteState(table[0, 2:5])
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)
        self.DeclareStateOutputPort("wheel_speed_command", self._command)
        self.DeclareStateOutputPort("reference_pose", self._pose)

    def _update(self, context, discrete_state):
        k = min(max(int(round((context.get_time() - self._start) / self._T_C)), 0), len(self._table) - 1)
        discrete_state.set_value(self._command, self._table[k, 0:2])
        discrete_state.set_value(self._pose, self._table[k, 2:5])
