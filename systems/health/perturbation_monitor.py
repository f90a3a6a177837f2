"""The perturbation tests (systems/health/perturbation.py) as a Drake block, and its place in a diagram."""

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.health.parameters import NO_CURRENTS
from slipnav.systems.health.perturbation import (
    FLAGS,
    FORCE_RESIDUAL,
    SIDEWAYS_PUSH,
    PerturbationParameters,
    force_model,
    perturbation_initial_state,
    perturbation_step,
)
from slipnav.systems.robot.parameters import RobotParameters


class PerturbationMonitor(LeafSystem):
    """Flags a wheel held, pushed or lifted and a push on the body (systems/health/perturbation.py).

    .. pydrake_system::

        name: PerturbationMonitor
        input_ports:
        - wheel_speed_command
        - encoders
        - mixed_estimate
        - motor_currents
        - slide_onset
        output_ports:
        - perturbation
        - force_residual
        - external_force

    - wheel_speed_command: the commands [v_R, v_L] (m/s) the motors get.
    - encoders: the wheel angles [theta_R, theta_L] (rad) the sensor checks pass on (the navigation
      subsystem's ``checked_encoders``: an excluded encoder's replacement).
    - mixed_estimate: the navigation's [v_t, v_n, omega, a_t, a_n].
    - motor_currents (optional): the drivers' current readings [i_R, i_L] (A); unconnected (a replayed
      log without currents) or NaN: no force test.
    - slide_onset (optional): the navigation's [1 while its slide-onset test holds, else 0]; unconnected:
      0.
    - perturbation: [wheel_R, wheel_L, yaw, body] (state, a copy of the flags that the update stores):
      a wheel 1 braked, 2 driven; yaw and body 1 when flagged.
    - force_residual: each side's force the motors do not explain per unit mass [e_R, e_L] (m/s^2,
      state; FORCE_CHANNELS).
    - external_force: 1 while the monitor flags a sideways push the navigation should take
      (sideways_push: the body test's lateral and slide conditions, confirmed, in an episode that held
      once while the held turn demand was below push_demand and raised no wheel or yaw flag, the sample
      before it included; state), else 0: the navigation's mixer reads it (mixing.mix_checked), one
      sample later as every flag. A push along the heading does not set it (the lateral tyre curve
      holds).

    Update every T_N: perturbation_step.

    Args:
        params: PerturbationParameters. radii: the believed rolling radii (r_R, r_L) (m). track_width: the
            believed track (m). T_N: period (s). robot: the believed robot for the force test (None: no
            force test). accelerations: the robot carries accelerometers (False: no body or force
            test, perturbation_step).
    """

    def __init__(
        self,
        params: PerturbationParameters,
        radii,
        track_width: float,
        T_N: float,
        robot: RobotParameters | None = None,
        accelerations: bool = True,
    ):
        super().__init__()
        self._p = params.validate()
        self._radii, self._b, self._T_N = (float(radii[0]), float(radii[1])), float(track_width), T_N
        self._robot = None if robot is None else force_model(robot)
        self._accelerations = bool(accelerations)
        self._command = self.DeclareVectorInputPort("wheel_speed_command", 2)
        self._encoders = self.DeclareVectorInputPort("encoders", 2)
        self._estimate = self.DeclareVectorInputPort("mixed_estimate", 5)
        self._currents = self.DeclareVectorInputPort("motor_currents", 2)
        self._sliding = self.DeclareVectorInputPort("slide_onset", 1)
        state0 = perturbation_initial_state()
        self._state = self.DeclareDiscreteState(state0)
        # the flags and the force residual, as outputs
        self._flags = self.DeclareDiscreteState(np.array([state0[i] for i in FLAGS], float))
        self._forces = self.DeclareDiscreteState(np.array([state0[i] for i in FORCE_RESIDUAL], float))
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)
        self.DeclareStateOutputPort("perturbation", self._flags)
        self.DeclareStateOutputPort("force_residual", self._forces)
        self._side = self.DeclareDiscreteState([state0[SIDEWAYS_PUSH]])  # a state: no Python output call
        self.DeclareStateOutputPort("external_force", self._side)

    def _update(self, context, discrete_state):
        currents = self._currents.Eval(context).tolist() if self._currents.HasValue(context) else NO_CURRENTS
        state = perturbation_step(
            discrete_state.get_value(self._state).tolist(),
            self._command.Eval(context).tolist(),
            self._encoders.Eval(context).tolist(),
            self._estimate.Eval(context).tolist(),
            self._p,
            self._radii,
            self._b,
            self._T_N,
            currents,
            self._robot,
            self._sliding.HasValue(context) and self._sliding.Eval(context).tolist()[0] > 0.5,
            self._accelerations,
        )
        discrete_state.set_value(self._state, state)
        discrete_state.set_value(self._flags, [state[i] for i in FLAGS])
        discrete_state.set_value(self._forces, [state[i] for i in FORCE_RESIDUAL])
        discrete_state.set_value(self._side, [state[SIDEWAYS_PUSH]])


def add_perturbation_monitor(
    builder,
    params,
    command_port,
    encoders_port,
    navigation,
    robot,
    T_N,
    currents_port=None,
    accelerations=True,
):
    """Add a PerturbationMonitor reading ``command_port``, ``encoders_port``, the navigation subsystem's
    mixed estimate and slide-onset flag and the drivers' ``currents_port`` (None: no force test);
    ``accelerations``: the robot carries accelerometers (perturbation_step); returns the monitor."""
    radii = (robot.radius_R, robot.radius_L)
    monitor = PerturbationMonitor(params, radii, robot.track_width, T_N, robot, accelerations)
    monitor = builder.AddSystem(monitor)
    monitor.set_name("Perturbation monitor")
    builder.Connect(command_port, monitor.GetInputPort("wheel_speed_command"))
    builder.Connect(encoders_port, monitor.GetInputPort("encoders"))
    builder.Connect(navigation.GetOutputPort("mixed_estimate"), monitor.GetInputPort("mixed_estimate"))
    builder.Connect(navigation.GetOutputPort("slide_onset"), monitor.GetInputPort("slide_onset"))
    if navigation.HasInputPort("external_force"):  # the sideways push, back to the mixer
        builder.Connect(monitor.GetOutputPort("external_force"), navigation.GetInputPort("external_force"))
    if currents_port is not None:
        builder.Connect(currents_port, monitor.GetInputPort("motor_currents"))
    return monitor
