"""The navigation and the perturbation monitor that watches it, as plain state over the same pure functions
as their diagram blocks: the part of the plain closed loop (scenarios/plain_loop.py) that the plain
replay of a sensor log (scenarios/replay_engines.py) runs alone.

Per sample t_k: ``step`` is the navigation diagram's output at t_k and its updates (NavigationLoop), with
the sideways push the monitor flagged before t_k; ``flags`` and ``forces`` are the monitor's outputs at
t_k; ``watch`` is the monitor's update at t_k, on the wheel speed command, the drivers' currents and the
navigation's outputs at t_k (add_perturbation_monitor's wiring).
"""

from slipnav.systems.health.perturbation import (
    FLAGS,
    FORCE_RESIDUAL,
    PerturbationParameters,
    force_model,
    perturbation_initial_state,
    perturbation_step,
    sideways_push,
)
from slipnav.systems.navigation.loop import LOOP_KEYS, NavigationLoop
from slipnav.systems.navigation.parameters import NavigationBelief
from slipnav.systems.robot.parameters import RobotParameters

MIXED_ESTIMATE_COLUMNS = [
    LOOP_KEYS.index(k) for k in ("est_v_t", "est_v_n", "est_omega", "est_a_t", "est_a_n")
]
"""The navigation's ``mixed_estimate`` output in a NavigationLoop row."""


class PlainMonitor:
    """The PerturbationMonitor as plain state (``state``: perturbation_initial_state's layout)."""

    def __init__(
        self, parameters: PerturbationParameters, robot: RobotParameters, T_N: float, accelerations: bool
    ):
        self.params = parameters.validate()
        self.state, self.radii, self.force = (
            perturbation_initial_state(),
            (robot.radius_R, robot.radius_L),
            force_model(robot),
        )
        self.track_width, self.T_N, self.accelerations = robot.track_width, T_N, accelerations

    def push(self):
        """The sideways push the navigation reads (sideways_push)."""
        return sideways_push(self.state)

    def step(self, command, nav: NavigationLoop, nav_row, current) -> None:
        """One T_N of the monitor on the ``command``, the navigation's checked encoders and estimate."""
        mixed = [nav_row[i] for i in MIXED_ESTIMATE_COLUMNS]
        self.state = perturbation_step(
            self.state,
            command,
            nav.checked_encoders,
            mixed,
            self.params,
            self.radii,
            self.track_width,
            self.T_N,
            current,
            self.force,
            nav.slide_onset,
            self.accelerations,
        )


class PlainNavigation:
    """The navigation diagram (NavigationLoop) and the PerturbationMonitor on its outputs, one T_N per
    sample (module docstring).

    Args:
        belief: what the navigation is given (NavigationBelief; its ``robot`` is the monitor's).
        monitor: the monitor's PerturbationParameters (None: no monitor, no push reaches the navigation).
    """

    def __init__(self, belief: NavigationBelief, monitor: PerturbationParameters | None = None):
        self.nav = NavigationLoop(belief)
        self.monitor = None
        if monitor is not None:
            accelerations = self.nav.geometry.accelerometer_sets > 0
            self.monitor = PlainMonitor(monitor, belief.robot, belief.rates.T_N, accelerations)

    def step(self, accelerometers, gyro: float, encoders, currents) -> tuple:
        """The navigation's sample k (NavigationLoop.step, with the monitor's sideways push at t_k): its
        outputs at t_k in LOOP_KEYS order."""
        push = False if self.monitor is None else self.monitor.push()
        return self.nav.step(accelerometers, gyro, encoders, currents, push)

    def flags(self) -> list:
        """The monitor's ``perturbation`` output at t_k (PERTURBATION_CHANNELS)."""
        return [self.monitor.state[i] for i in FLAGS]

    def forces(self) -> list:
        """The monitor's ``force_residual`` output at t_k (FORCE_CHANNELS)."""
        return [self.monitor.state[i] for i in FORCE_RESIDUAL]

    def watch(self, command, nav_row, currents) -> None:
        """The monitor's update at t_k on the wheel speed ``command``, the drivers' ``currents`` and the
        navigation's row ``nav_row`` of this sample."""
        self.monitor.step(command, self.nav, nav_row, currents)
