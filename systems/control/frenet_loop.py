"""The path-following error dynamics as a scalar-generic Drake system, for linearisation (issue 5).

Follower I(15)-(16) closed around a kinematic unicycle, written in the Serret-Frenet errors of
Indiveri I(11)-(13) on a path of constant curvature kappa (0: straight line, 1/R: circle), sampled at
T_C with the follower's outputs held over the sample (forward Euler, as the T_C follower block does):

    s1+    = s1    + T_C (-s_dot (1 - kappa y1) + u cos theta)
    y1+    = y1    + T_C (-kappa s_dot s1 + u sin theta)
    theta+ = theta + T_C theta_dot

with (s_dot, theta_dot) = I(15)-(16). Zero error is an equilibrium for every kappa. The system is a
TemplateSystem (LeafSystem_[T]) so that Drake's Linearize can differentiate it with AutoDiffXd.
"""

import pydrake.math as drake_math
from pydrake.systems.framework import LeafSystem_
from pydrake.systems.scalar_conversion import TemplateSystem
from slipnav.systems.control.path_follower import PathFollowerParameters, path_following_law


def frenet_error_step(x, kappa: float, u: float, p: PathFollowerParameters, T_C: float, ops=drake_math):
    """One T_C sample of the closed-loop error map (list of 3, any scalar type)."""
    s1, y1, theta = x
    s_dot, theta_dot, _ = path_following_law(s1, y1, theta, kappa, u, p, ops)
    return [
        s1 + T_C * (-s_dot * (1.0 - kappa * y1) + u * ops.cos(theta)),
        y1 + T_C * (-kappa * s_dot * s1 + u * ops.sin(theta)),
        theta + T_C * theta_dot,
    ]


@TemplateSystem.define("FrenetFollowingErrors_")
def FrenetFollowingErrors_(T):
    class Impl(LeafSystem_[T]):
        """Closed-loop Frenet errors [s1, y1, theta] of the path follower, updated every T_C.

        .. pydrake_system::

            name: FrenetFollowingErrors
            output_ports:
            - errors

        Args:
            params: PathFollowerParameters (not range-checked here, so that unstable gains can be
                analysed). kappa: path curvature (1/m). u: speed (m/s). T_C: period (s).
        """

        def _construct(self, params, kappa, u, T_C, converter=None):
            LeafSystem_[T].__init__(self, converter)
            self._params, self._kappa, self._u, self._T_C = params, kappa, u, T_C
            state = self.DeclareDiscreteState(3)
            self.DeclareStateOutputPort("errors", state)
            self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

        def _construct_copy(self, other, converter=None):
            Impl._construct(self, other._params, other._kappa, other._u, other._T_C, converter=converter)

        def _update(self, context, discrete_state):
            x = context.get_discrete_state_vector().CopyToVector()
            discrete_state.set_value(
                0, frenet_error_step(list(x), self._kappa, self._u, self._params, self._T_C)
            )

    return Impl


FrenetFollowingErrors = FrenetFollowingErrors_[None]
