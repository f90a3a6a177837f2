"""The differential-drive robot as a Drake block (DifferentialDrivePlant): a rigid body with real tyre slip
(systems/robot/contact.py), DC motors and a sampled wheel-speed loop (systems/robot/motors.py), continuous or
advanced by semi-implicit steps (systems/robot/dynamics.py), with the physical parameters of
systems/robot/parameters.py.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import BasicVector, LeafSystem
from slipnav.systems.ranges import require_in
from slipnav.systems.robot.contact import NO_DISTURBANCE, tyre_slip
from slipnav.systems.robot.dynamics import plant_advance, plant_derivatives, substeps_per
from slipnav.systems.robot.motors import MOTORS_ON, motor_current, motor_currents, speed_loop_update
from slipnav.systems.robot.parameters import RobotParameters

DEFAULT_TIME_STEP = 5e-4
"""Default semi-implicit step of the discrete plant (s). Against the continuous model (DOP853, rtol 1e-9),
first-order convergence; at 0.5 ms: corner 0.44 mm / 1.5 mm/s, square 0.39 mm / 1.6 mm/s (max position /
speed error over the run), circle (Kurt3D) 0.02 mm until its final emergency stop, 13 mm / 0.06 m/s after."""


class DifferentialDrivePlant(LeafSystem):
    """Rigid-body robot with slipping tyres, felt shoes, DC motors and a sampled PI speed loop.

    .. pydrake_system::

        name: DifferentialDrivePlant
        input_ports:
        - wheel_speed_command
        - disturbance
        - motor_enable
        output_ports:
        - state
        - body_acceleration
        - wheel_angles
        - wheel_speeds
        - tyre_slip
        - motor_currents

    - wheel_speed_command: commanded circumferential wheel speeds [v_R, v_L] (m/s).
    - disturbance: perturbations in NO_DISTURBANCE's layout (optional: unconnected, nothing acts).
    - motor_enable: [enable_R, enable_L] in MOTORS_ON's layout (optional: unconnected, both driven); 0
      switches a motor off (open circuit, the wheel free-wheels; a coasting run).
    - state: PlantState [x, y, phi, v_t, v_n, omega, theta_R, theta_L, w_R, w_L].
    - body_acceleration: true absolute body-frame accelerations [a_t, a_n, omega_dot] (m/s^2, rad/s^2).
    - wheel_angles: [theta_R, theta_L] (rad), for the encoders.
    - wheel_speeds: circumferential speeds [r_R*w_R, r_L*w_L] with the true rolling radii (m/s).
    - tyre_slip: [kappa_R, kappa_L, alpha_R, alpha_L]: slip ratios and slip angles (rad).
    - motor_currents: the true armature currents [i_R, i_L] (A) at ``state`` with the voltages held since
      the last PI sample (motor_currents), for the drivers' current sense (systems/robot/sensors.py).

    Two time models, as Drake's MultibodyPlant offers:

    - ``time_step = 0``: continuous state (PlantState) integrated by the simulator's integrator; the PI
      loop is a periodic discrete update at ``speed_loop_period`` holding the voltages (SpeedLoopState).
    - ``time_step > 0``: discrete state, advanced every ``update_period`` by plant_advance: semi-implicit
      steps of ``time_step`` with the PI loop sampled every ``speed_loop_period``. ``time_step`` must
      divide both periods. The body acceleration at the new state is part of the discrete state, so
      that the output at t_k is the acceleration at x(t_k) with the voltage held since the last PI sample,
      exactly as in the continuous model.

    Args:
        params: RobotParameters.
        initial_pose: (x, y, phi) of the default context.
        initial_speed: forward speed v_t of the default context (wheels rolling), m/s.
        time_step: 0 (continuous) or the semi-implicit integration step (s).
        update_period: period of the discrete update when ``time_step > 0`` (s), e.g. the sensors' T_N.
    """

    def __init__(
        self,
        params: RobotParameters,
        initial_pose=(0.0, 0.0, 0.0),
        initial_speed=0.0,
        time_step: float = 0.0,
        update_period: float | None = None,
    ):
        super().__init__()
        if time_step != 0.0:  # 0: continuous
            require_in("plant time_step", time_step, "0 (continuous) or (0, 0.01] s")
        self._params = params
        self._time_step = time_step
        x0 = np.zeros(10)
        x0[0:3] = initial_pose
        x0[3] = initial_speed
        x0[8], x0[9] = initial_speed / params.radius_R, initial_speed / params.radius_L
        self._command_port = self.DeclareVectorInputPort("wheel_speed_command", 2)
        self._disturbance_port = self.DeclareVectorInputPort("disturbance", len(NO_DISTURBANCE))
        self._enable_port = self.DeclareVectorInputPort("motor_enable", len(MOTORS_ON))
        if time_step > 0.0:
            self._declare_discrete(x0, time_step, update_period)
        else:
            self._declare_continuous(x0)
        self.DeclareVectorOutputPort(
            "wheel_angles", 2, self._calc_wheel_angles, prerequisites_of_calc={self._state_ticket}
        )
        self.DeclareVectorOutputPort(
            "wheel_speeds", 2, self._calc_wheel_speeds, prerequisites_of_calc={self._state_ticket}
        )
        self.DeclareVectorOutputPort(
            "tyre_slip", 4, self._calc_tyre_slip, prerequisites_of_calc={self._state_ticket}
        )

    def _declare_continuous(self, x0):
        self.DeclareContinuousState(BasicVector(x0), 0, 0, 10)
        self._loop = self.DeclareDiscreteState(4)
        self.DeclarePeriodicDiscreteUpdateEvent(
            period_sec=self._params.speed_loop_period, offset_sec=0.0, update=self._update_speed_loop
        )
        self._state_ticket = self.xc_ticket()
        self.DeclareVectorOutputPort("state", 10, self._calc_state, prerequisites_of_calc={self.xc_ticket()})
        self.DeclareVectorOutputPort(
            "motor_currents",
            2,
            self._calc_currents,
            prerequisites_of_calc={self.all_state_ticket(), self._enable_port.ticket()},
        )
        self.DeclareVectorOutputPort(
            "body_acceleration",
            3,
            self._calc_acceleration,
            prerequisites_of_calc={
                self.all_state_ticket(),
                self._disturbance_port.ticket(),
                self._enable_port.ticket(),
            },
        )

    def _declare_discrete(self, x0, time_step, update_period):
        if update_period is None:
            raise ValueError("update_period is required with a plant time_step > 0")
        substeps_per(self._params.speed_loop_period, time_step, "speed_loop_period")
        self._steps_per_update = substeps_per(update_period, time_step, "update_period")
        self._x = self.DeclareDiscreteState(x0)
        self._loop = self.DeclareDiscreteState(4)
        currents = (motor_current(0.0, x0[8], self._params), motor_current(0.0, x0[9], self._params))
        self._acc = self.DeclareDiscreteState(np.array(plant_derivatives(x0, currents, self._params)[1]))
        self._currents_state = self.DeclareDiscreteState(np.array(currents))
        self.DeclarePeriodicDiscreteUpdateEvent(update_period, 0.0, self._update_discrete)
        self._state_ticket = self.xd_ticket()
        self.DeclareStateOutputPort("state", self._x)
        self.DeclareStateOutputPort("body_acceleration", self._acc)
        self.DeclareStateOutputPort("motor_currents", self._currents_state)

    @property
    def params(self) -> RobotParameters:
        return self._params

    @property
    def time_step(self) -> float:
        return self._time_step

    def get_command_input_port(self):
        return self._command_port

    def _plant_state(self, context):
        if self._time_step > 0.0:
            return context.get_discrete_state(self._x).get_value()
        return context.get_continuous_state_vector().CopyToVector()

    def _disturbance(self, context):
        port = self._disturbance_port
        return port.Eval(context).tolist() if port.HasValue(context) else NO_DISTURBANCE

    def _motor_enable(self, context):
        port = self._enable_port
        return port.Eval(context).tolist() if port.HasValue(context) else MOTORS_ON

    def _currents(self, context, x):
        loop = context.get_discrete_state(self._loop).get_value()
        return motor_currents(loop, x, self._params, self._motor_enable(context))

    def DoCalcTimeDerivatives(self, context, derivatives):  # noqa: N802 (Drake API)
        if self._time_step > 0.0:
            return
        x = context.get_continuous_state_vector().CopyToVector()
        xdot, _ = plant_derivatives(x, self._currents(context, x), self._params, self._disturbance(context))
        derivatives.get_mutable_vector().SetFromVector(xdot)

    def _update_speed_loop(self, context, discrete_state):
        x = context.get_continuous_state_vector().CopyToVector()
        command = self._command_port.Eval(context)
        loop = context.get_discrete_state(self._loop).get_value()
        discrete_state.set_value(
            self._loop,
            speed_loop_update(loop, command, (x[8], x[9]), self._params, self._motor_enable(context)),
        )

    def _update_discrete(self, context, discrete_state):
        step_index = round(context.get_time() / self._time_step)
        enable = self._motor_enable(context)
        # Floats, not numpy scalars, into the pure functions (numpy scalar arithmetic is several times
        # slower); the update's buffer holds the block's own state at t_k.
        state, loop, acc = plant_advance(
            discrete_state.get_value(self._x).tolist(),
            discrete_state.get_value(self._loop).tolist(),
            self._command_port.Eval(context).tolist(),
            step_index,
            self._steps_per_update,
            self._time_step,
            self._params,
            self._disturbance(context),
            enable,
        )
        discrete_state.set_value(self._x, state)
        discrete_state.set_value(self._loop, loop)
        discrete_state.set_value(self._acc, acc)
        discrete_state.set_value(self._currents_state, motor_currents(loop, state, self._params, enable))

    def _calc_state(self, context, output: BasicVector):
        output.SetFromVector(context.get_continuous_state_vector().CopyToVector())

    def _calc_acceleration(self, context, output: BasicVector):
        x = context.get_continuous_state_vector().CopyToVector()
        _, acc = plant_derivatives(x, self._currents(context, x), self._params, self._disturbance(context))
        output.SetFromVector(acc)

    def _calc_currents(self, context, output: BasicVector):
        x = context.get_continuous_state_vector().CopyToVector()
        output.SetFromVector(self._currents(context, x))

    def _calc_wheel_angles(self, context, output: BasicVector):
        output.SetFromVector(self._plant_state(context)[6:8])

    def _calc_wheel_speeds(self, context, output: BasicVector):
        x = self._plant_state(context)
        output.SetFromVector([self._params.radius_R * x[8], self._params.radius_L * x[9]])

    def _calc_tyre_slip(self, context, output: BasicVector):
        output.SetFromVector(tyre_slip(self._plant_state(context), self._params))
