"""Build and simulate a scenario: ``run_scenario`` returns the run artifact of docs/artifacts.md (its
arrays, summary, sensor log and model: a RunResult), which ``write_artifacts`` writes.

A run is planned (scenarios/run_plan.py: the overrides applied), built (the open-loop or closed-loop
diagram), simulated in steps of 0.1 s with its log drained and its navigation checked after each, and
recorded (scenarios/artifact_arrays.py, scenarios/run_summary.py).
"""

from __future__ import annotations

import dataclasses as dc
import math
import time

import numpy as np
from pydrake.systems.analysis import Simulator
from slipnav.diagrams.closed_loop import build_closed_loop_diagram
from slipnav.diagrams.loggers import LoggedDiagram
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.artifact_arrays import SERIES_KEYS, collect_arrays
from slipnav.scenarios.artifacts import RunResult, write_artifacts
from slipnav.scenarios.config import Scenario
from slipnav.scenarios.interrupt import deferred_interrupt
from slipnav.scenarios.log_drain import LogDrain
from slipnav.scenarios.navigation_health import NavigationHealth
from slipnav.scenarios.run_plan import (
    RunOptions,
    RunPlan,
    as_scenario_error,
    check_fault_starts,
    end_time,
    plan_run,
    standstill_for,
)
from slipnav.scenarios.run_summary import belief_model, run_sensor_log, run_summary
from slipnav.scenarios.tolerances import plant_record
from slipnav.scenarios.trajectories import Path

__all__ = ["RunOptions", "RunResult", "run_scenario", "write_artifacts"]
"""The Python API (docs/python-api.md): run_scenario (its overrides: RunOptions) and write_artifacts,
which writes its RunResult."""


def run_scenario(scenario: Scenario, options: RunOptions | None = None, **overrides) -> RunResult:
    """Simulate ``scenario`` and collect the run artifact.

    ``options`` (RunOptions: the command line's --seed, --duration, --no-slip-control, --speed-law,
    --open-loop, --tolerances, --localisation and the fault list; None keeps the scenario's) and
    ``overrides``, RunOptions' fields as keywords over them (``run_scenario(scenario, seed=1,
    duration=2.0)``), override the scenario. Navigation and control read the nominal robot refined by a
    model (``scenario.belief()``); the plant and sensors are the real robot
    (``scenario.plant_parameters``), whose drawn values the artifact records (``plant_*`` scalars, the
    summary's ``plant``). A closed-loop run ends when the controller has finished its
    trajectory (progress Pi at its end) or path (virtual target at its end) plus ``settle_time``, or at
    the duration limit (default: three times the nominal time). Completion is then judged on the true
    pose (judge_completion): ``summary["completed"]``.
    """
    plan = plan_run(scenario, dc.replace(options or RunOptions(), **overrides))
    run = build_run(plan)
    simulated = simulate_run(plan, run)
    record = plant_record(plan.truth.plant, plan.truth.sensors)
    arrays = run_arrays(plan, run, simulated, record)
    summary = run_summary(
        plan,
        arrays,
        record,
        run.path,
        run.start_time,
        simulated.controller_done,
        simulated.health,
        simulated.wall,
    )
    return RunResult(
        scenario=plan.scenario,
        seed=plan.truth.seed,
        arrays=arrays,
        summary=summary,
        reference=plan.reference,
        sensor_log=run_sensor_log(plan, arrays, run.initial_speed, run.start_time),
        model=belief_model(plan.scenario, plan.belief),
    )


@dc.dataclass
class BuiltRun:
    """A run's diagram and what its simulation and summary need besides the RunPlan.

    Args:
        built: the diagram and its loggers. path: the path the closed loop follows (None: open loop).
        start_time: the standstill before the controller starts (s). nominal: the nominal end (s).
        initial_speed: the robot's initial forward speed (m/s; 0 for a max_speed closed loop).
    """

    built: LoggedDiagram
    path: Path | None
    start_time: float
    nominal: float
    initial_speed: float


def build_run(plan: RunPlan) -> BuiltRun:
    """The run's open-loop (feed-forward of the reference) or closed-loop diagram; raises ScenarioError
    for what the builders reject."""
    belief, scenario, truth = plan.belief, plan.scenario, plan.truth
    if plan.open_loop:
        start = standstill_for(scenario, truth.initial_speed)
        v_R, v_L = plan.reference.wheel_speeds(belief.robot.track_width)
        built = as_scenario_error(
            lambda: build_open_loop_diagram(
                truth,
                belief,
                np.column_stack([v_R, v_L]),
                np.column_stack([plan.reference.x, plan.reference.y, plan.reference.phi]),
                start_time=start,
            )
        )
        return BuiltRun(built, None, start, plan.reference.duration + start, truth.initial_speed)
    truth, control, nominal = plan.closed_loop()
    built = as_scenario_error(lambda: build_closed_loop_diagram(truth, belief, control))
    return BuiltRun(built, control.path, control.start_time, nominal, truth.initial_speed)


@dc.dataclass
class SimulatedRun:
    """A simulated run: its drained log, the navigation's health, when the controller finished its
    reference (not where the robot is; None: never) and the simulation's wall time (s)."""

    simulator: Simulator
    drain: LogDrain
    health: NavigationHealth
    controller_done: float | None
    wall: float


def simulate_run(plan: RunPlan, run: BuiltRun) -> SimulatedRun:
    """Simulate the run in steps of 0.1 s, draining the log and checking the navigation after each, until
    its end time: the reference's end (open loop), else the controller's completion plus ``settle_time``
    (at most three times the nominal time plus the settle time), or --duration. A lost estimate stops the
    run early (summary "aborted"); Ctrl-C is raised between steps."""
    scenario, open_loop = plan.scenario, plan.open_loop
    # Open loop: the reference's end; closed loop: a generous limit, cut at completion below.
    nominal = run.nominal if open_loop else 3.0 * run.nominal + scenario.settle_time
    limit = end_time(scenario, nominal, plan.duration)
    check_fault_starts(plan.truth.faults, limit)
    simulator = make_simulator(run.built.diagram, plan.truth.seed, plan.belief.robot.speed_loop_period)
    context = simulator.get_context()
    drain = LogDrain(run.built.loggers, context, int(math.ceil(limit / plan.rates.T_N)) + 2)
    health = NavigationHealth(run.built.diagram, context)
    wall_start = time.perf_counter()
    controller_done = None  # when the controller finished its reference (not where the robot is)
    done = None if open_loop else _completion_check(drain, scenario.mode, plan.reference, run.path)
    with deferred_interrupt() as pending:
        t = 0.0
        while t < limit - 1e-12:
            t = min(t + 0.1, limit)
            simulator.AdvanceTo(t)
            new = drain.drain()
            pending.raise_if_interrupted()
            if health.check(drain, new) is not None:
                break  # the estimate is lost: stop here, say why (summary "aborted", exit status 3)
            if done is not None and controller_done is None:
                controller_done = done(new)
                if controller_done is not None and plan.duration is None and scenario.duration is None:
                    limit = min(limit, controller_done + scenario.settle_time)
    if open_loop and run.nominal <= limit and health.aborted is None:
        controller_done = run.nominal
    wall = time.perf_counter() - wall_start
    return SimulatedRun(simulator, drain, health, controller_done, wall)


def run_arrays(plan: RunPlan, run: BuiltRun, simulated: SimulatedRun, record: dict) -> dict:
    """The artifact arrays of a simulated run: the logged series (NaN where the diagram logs none), the
    nominal scalars and the real robot's ``plant_*`` scalars (``record``: plant_record)."""
    context = simulated.simulator.get_context()
    arrays = collect_arrays(simulated.drain.loggers(), context, plan.truth.plant, copy=False)
    n = len(arrays["t"])
    for key in SERIES_KEYS:
        arrays.setdefault(key, np.full(n, np.nan))
    robot = plan.belief.robot
    arrays.update(
        path_length=np.array(plan.reference.length if run.path is None else run.path.length),
        T_N=np.array(plan.rates.T_N),
        T_C=np.array(plan.rates.T_C),
        V_m=np.array(robot.wheel_speed_limit),
        track_width=np.array(robot.track_width),
        start_time=np.array(run.start_time),
        **{f"plant_{key}": np.array(value) for key, value in record.items()},
    )
    return arrays


def _completion_check(drain: LogDrain, mode, reference, path):
    """A function of the newly drained samples (a slice) returning the completion time once the reference
    is finished, else None."""
    if mode == "trajectory":
        name, end = "progress", reference.num_samples - 1
    else:
        name, end = "virtual_target", path.length - 1e-9

    def done(new: slice):
        values = drain.signal(name)[0, new]
        hits = np.flatnonzero(values >= end)
        return float(drain.t[new][hits[0]]) if len(hits) else None

    return done
