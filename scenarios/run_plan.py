"""What a run of a scenario is before it is built: the overrides checked (``check_run_options``), the
reference trajectory, the path the closed loop follows, its ControlSettings and the run's end time."""

from __future__ import annotations

import dataclasses as dc

from slipnav.diagrams.closed_loop import ControlSettings
from slipnav.diagrams.records import Belief, Truth
from slipnav.scenarios.config import (
    MAX_DURATION,
    Scenario,
    ScenarioError,
    check_duration,
    with_paper_mode,
)
from slipnav.scenarios.trajectories import (
    Path,
    Trajectory,
    TrajectoryError,
    build_path,
    build_trajectory,
    trajectory_along_path,
    trajectory_path,
)
from slipnav.systems.checks import require_seed
from slipnav.systems.rates import SampleRates


@dc.dataclass(frozen=True)
class RunOptions:
    """run_scenario's overrides of a scenario (the command line's flags); None keeps the scenario's.

    Args:
        seed: the noise seed and the tolerances' draw (--seed; an integer 0 .. 2**31-1).
        duration: the run's end (s; --duration; None: the scenario's duration or its reference's end).
        slip_control: a trajectory scenario's slip control on or off (--no-slip-control).
        speed_law: a max_speed scenario's speed law, ``bounded`` or ``constant`` (--speed-law).
        open_loop: the feed-forward of the reference instead of the closed loop (--open-loop).
        tolerances: True draws the plant from the tolerance preset where the scenario sets no bound
            (--tolerances).
        faults: FaultEvents replacing the scenario's ``faults``.
        localisation: what the follower localises by: fused, odometry, gyrodometry, truth (--localisation).
    """

    seed: int | None = None
    duration: float | None = None
    slip_control: bool | None = None
    speed_law: str | None = None
    open_loop: bool | None = None
    tolerances: bool = False
    faults: object = None
    localisation: str | None = None

    def runs_open_loop(self, scenario: Scenario) -> bool:
        """Whether the run is open loop: ``open_loop``, else the scenario's ``controller: feedforward``."""
        return scenario.controller == "feedforward" if self.open_loop is None else self.open_loop


def check_run_options(scenario: Scenario, options: RunOptions) -> None:
    """The overrides of run_scenario (the command line's flags), checked against the scenario before
    anything is built; raises ScenarioError naming the flag (and the parameter)."""
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"scenario must be a Scenario (load_scenario(...)), got {scenario!r}")
    if not isinstance(options, RunOptions):
        raise ScenarioError(f"options must be a RunOptions, got {options!r}")
    scenario.validate()  # a Scenario built or changed in Python
    if options.seed is not None:
        as_scenario_error(lambda: require_seed(options.seed, "--seed"))
    if options.duration is not None:
        check_duration(scenario, options.duration)
    for name in ("slip_control", "open_loop"):
        value = getattr(options, name)
        if value is not None and not isinstance(value, bool):
            raise ScenarioError(f"{name}={value!r} is out of range: allowed True, False or None")
    open_loop = options.runs_open_loop(scenario)
    how = "this run is open loop (--open-loop or controller: feedforward)"
    speed_law = options.speed_law
    if speed_law is not None:
        if speed_law not in ("bounded", "constant"):
            raise ScenarioError(f"--speed-law={speed_law!r} is unknown: allowed bounded, constant")
        if scenario.mode != "max_speed":
            raise ScenarioError(
                f"--speed-law (speed_law) applies to max_speed scenarios only: {scenario.name!r} is mode "
                f"{scenario.mode}"
            )
        if open_loop:
            raise ScenarioError(f"--speed-law (speed_law) applies to the closed loop only: {how}")
    if options.slip_control is not None:
        if scenario.mode != "trajectory":
            raise ScenarioError(
                f"--no-slip-control (slip_control) applies to trajectory scenarios only: {scenario.name!r} "
                f"is mode {scenario.mode} (its speed comes from the speed law)"
            )
        if open_loop:
            raise ScenarioError(f"--no-slip-control (slip_control) applies to the closed loop only: {how}")


def as_scenario_error(check):
    """``check()``, with a ValueError it raises (a builder's or a check's, naming the parameter) raised as
    a ScenarioError."""
    try:
        return check()
    except ValueError as e:
        raise ScenarioError(str(e)) from None


def reference_for(scenario: Scenario) -> tuple[Trajectory, float]:
    """The scenario's reference trajectory sampled at T_C and the robot's initial forward speed.

    A path (max_speed mode) gives the trajectory of driving it at V_m/2 (or ``path_speed``): the
    feed-forward reference, and the plotted reference of the closed loop.
    """
    rates = scenario.rates()
    try:
        if scenario.mode == "trajectory":
            trajectory = build_trajectory(scenario.trajectory, rates.T_C)
            return trajectory, scenario.trajectory.initial_speed
        robot = scenario.belief().robot
        speed = scenario.path_speed or 0.5 * robot.wheel_speed_limit
        return trajectory_along_path(build_path(scenario.path), speed, rates.T_C), speed
    except TrajectoryError as e:
        raise ScenarioError(str(e)) from None


def follower_path(scenario: Scenario) -> Path:
    """The geometric path the closed loop follows."""
    try:
        if scenario.mode == "trajectory":
            return trajectory_path(scenario.trajectory)
        return build_path(scenario.path)
    except TrajectoryError as e:
        raise ScenarioError(str(e)) from None


def closed_loop_settings(scenario: Scenario, slip_control: bool, speed_law: str):
    """(ControlSettings, initial forward speed, nominal duration) of the scenario's closed loop."""
    reference, initial_speed = reference_for(scenario)
    path = follower_path(scenario)
    if scenario.mode == "max_speed":
        initial_speed = 0.0
        nominal = path.length / (0.5 * scenario.belief().robot.wheel_speed_limit)
    else:
        nominal = reference.duration
    start = standstill_for(scenario, initial_speed)
    control = ControlSettings(
        mode=scenario.mode,
        path=path,
        trajectory=reference,
        follower=scenario.follower,
        step_size=scenario.slip_control,
        slip_control=slip_control,
        speed_law=speed_law,
        start_time=start,
        localisation=scenario.localisation,
    )
    return control, initial_speed, nominal + start


def standstill_for(scenario: Scenario, initial_speed: float) -> float:
    """The standstill before the controller starts: ``standstill_time`` for a run that starts at rest,
    else 0 (a robot already moving cannot stand)."""
    return scenario.standstill_time if initial_speed == 0.0 else 0.0


def end_time(scenario: Scenario, nominal: float, duration: float | None) -> float:
    """--duration, else the scenario's duration, else the nominal end plus the settle time (at most
    MAX_DURATION)."""
    if duration is not None:
        return check_duration(scenario, duration)
    if scenario.duration is not None:
        return scenario.duration
    return min(nominal + scenario.settle_time, MAX_DURATION)


def check_fault_starts(faults, limit: float) -> None:
    """Every fault starts before the run's end ``limit`` (s): one starting later would never happen, and
    the run would report a fault-free robot as a faulty one's; ScenarioError naming faults[i].start."""
    for i, event in enumerate(faults or ()):
        if event.start >= limit:
            raise ScenarioError(
                f"faults[{i}].start={event.start!r} is out of range: allowed [0, {limit:.6g}) s (the run "
                "ends by then: its duration, --duration, or the reference's end and settle_time)"
            )


@dc.dataclass
class RunPlan:
    """A scenario's run with run_scenario's overrides applied: what is built and simulated.

    Args:
        scenario: the scenario as run (in paper mode if asked, with the --localisation override).
        duration (--duration; None: the scenario's end), speed_law, slip_control, open_loop, tolerances:
        the run's settings, the scenario's where not overridden.
        rates: the sample periods. belief: what navigation and control read (Scenario.belief: the
        nominal robot refined by a model). truth: the simulated robot (diagrams.records.Truth: the real
        robot and sensors, the seed, the faults, the scenario's plant time step and initial pose, and the
        reference's initial speed, reference_for's; a max_speed closed loop starts at rest instead);
        deviations: the real robot's and sensors' drawn deviations from the nominal values.
        reference: the reference trajectory (reference_for's).
    """

    scenario: Scenario
    duration: float | None
    speed_law: str
    slip_control: bool
    open_loop: bool
    tolerances: bool
    rates: SampleRates
    belief: Belief
    truth: Truth
    deviations: dict
    reference: Trajectory

    def closed_loop(self) -> tuple[Truth, ControlSettings, float]:
        """The run's closed loop: its Truth (a max_speed run starts at rest), its ControlSettings and its
        nominal end (s), closed_loop_settings'."""
        settings = closed_loop_settings(self.scenario, self.slip_control, self.speed_law)
        control, initial_speed, nominal = settings
        return dc.replace(self.truth, initial_speed=initial_speed), control, nominal


def plan_run(scenario: Scenario, options: RunOptions) -> RunPlan:
    """The RunPlan of ``scenario`` with the overrides ``options`` (run_scenario's docstring), checked
    first (check_run_options); raises ScenarioError naming the flag."""
    check_run_options(scenario, options)
    scenario = with_paper_mode(scenario)
    if options.localisation is not None:
        scenario = dc.replace(scenario, localisation=options.localisation).validate()
    seed = scenario.seed if options.seed is None else int(options.seed)
    speed_law = scenario.speed_law if options.speed_law is None else options.speed_law
    slip_control = scenario.slip_control_enabled if options.slip_control is None else options.slip_control
    rates = scenario.rates()
    belief = scenario.belief()
    plant, sensor_params, deviations = scenario.plant_parameters(seed, options.tolerances)
    reference, initial_speed = reference_for(scenario)
    return RunPlan(
        scenario=scenario,
        duration=options.duration,
        speed_law=speed_law,
        slip_control=slip_control,
        open_loop=options.runs_open_loop(scenario),
        tolerances=options.tolerances,
        rates=rates,
        belief=belief,
        truth=Truth(
            sensors=sensor_params,
            seed=seed,
            plant=plant,
            initial_pose=tuple(scenario.initial_pose),
            initial_speed=initial_speed,
            plant_time_step=scenario.plant_time_step,
            faults=scenario.faults if options.faults is None else options.faults,
        ),
        deviations=deviations,
        reference=reference,
    )
