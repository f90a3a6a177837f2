"""Deterministic pose integration S(21), Seyr & Jakubek §IV-F (forward Euler of S(1))."""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem


def pose_step(pose, v_t: float, v_n: float, omega: float, T_N: float):
    """S(21): x += (v_t cos phi - v_n sin phi) T_N, y += (v_t sin phi + v_n cos phi) T_N, phi += omega T_N."""
    x, y, phi = pose
    c, s = math.cos(phi), math.sin(phi)
    return [x + (v_t * c - v_n * s) * T_N, y + (v_t * s + v_n * c) * T_N, phi + omega * T_N]


class PoseIntegrator(LeafSystem):
    """Dead reckoning S(21) of a body velocity, every T_N.

    .. pydrake_system::

        name: PoseIntegrator
        input_ports:
        - body_velocity
        output_ports:
        - pose

    - body_velocity: [v_t, v_n, omega] of the current sample k.
    - pose: [x, y, phi] (state): pose_k; the update at t_k makes it pose_k+1.

    Args:
        T_N: navigation period (s). initial_pose: [x, y, phi].
    """

    def __init__(self, T_N: float, initial_pose=(0.0, 0.0, 0.0)):
        super().__init__()
        self._T_N = T_N
        self._vel = self.DeclareVectorInputPort("body_velocity", 3)
        self._pose = self.DeclareDiscreteState(np.asarray(initial_pose, float))
        self.DeclareStateOutputPort("pose", self._pose)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _update(self, context, discrete_state):
        v_t, v_n, omega = self._vel.Eval(context).tolist()
        pose = discrete_state.get_mutable_value(self._pose)  # read and written in place: one call
        pose[:] = pose_step(pose.tolist(), v_t, v_n, omega, self._T_N)
