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

    - inputs, perturbation_step's arguments: wheel_speed_command (command), encoders (the navigation
      subsystem's ``checked_encoders``), mixed_estimate (estimate), motor_currents (optional;
      unconnected: no force test) and slide_onset (optional: 1 while the navigation's slide-onset test
      holds; unconnected: 0).
    - outputs, states that the update stores: perturbation, the flags (PERTURBATION_CHANNELS);
      force_residual (FORCE_CHANNELS); external_force, 1 while the monitor flags a sideways push
      (sideways_push), which the navigation's mixer reads (mixing.mix_checked).

    Update every T_N: perturbation_step.

    Args: perturbation_step's params, radii, track_width, T_N, robot and accelerations.
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
