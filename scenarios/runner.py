"""Build, simulate and record a scenario: the run artifact of docs/artifacts.md.

``run_scenario`` returns the artifact arrays and summary; ``write_artifacts`` writes
``DIR/<stem>.npz``, the figures and ``DIR/<stem>.summary.json`` (stem: ``artifact_stem``, e.g.
``corner-seed0``), atomically.

Every array is logged on the T_N grid by Drake loggers, which publish at t_k before the discrete updates
of t_k: a row holds the true continuous state at t_k and the discrete signals (sensor samples ``meas_*``,
commands) as the blocks updating at t_k read them.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import os
import shutil
import tempfile
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.diagrams.closed_loop import ControlSettings, build_closed_loop_diagram
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.config import MAX_DURATION, Scenario, ScenarioError, check_duration, with_paper_mode
from slipnav.scenarios.interrupt import deferred_interrupt
from slipnav.scenarios.metrics import ESTIMATES, final_position_error, moving_alpha
from slipnav.scenarios.model import RobotModel, model_text
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_chunks, sensor_log_from_arrays
from slipnav.scenarios.tolerances import plant_record
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
from slipnav.systems.faults import SENSOR_CHANNELS
from slipnav.systems.perturbation_monitor import FORCE_CHANNELS, PERTURBATION_CHANNELS, perturbation_report
from slipnav.systems.plant import RobotParameters, tyre_slip
from slipnav.systems.sensor_health import health_report

TRUTH_KEYS = (
    "true_x true_y true_phi true_v_t true_v_n true_omega true_alpha true_wheel_R true_wheel_L".split()
)
ESTIMATE_KEYS = "est_x est_y est_phi est_v_t est_v_n est_omega est_alpha".split()
BASELINE_KEYS = "odo_x odo_y odo_phi gyro_x gyro_y gyro_phi".split()
NAVIGATION_KEYS = "C1 C2 C3 delta_v".split()
CONTROL_KEYS = "step_size progress ref_x ref_y ref_phi cmd_R cmd_L V1".split()
SENSOR_KEYS = "meas_a_t1 meas_a_n1 meas_a_t2 meas_a_n2 meas_gyro meas_enc_R meas_enc_L".split()
SLIP_KEYS = "true_slip_R true_slip_L true_theta_R true_theta_L".split()
NAVIGATION_EXTRA_KEYS = "est_a_t est_a_n est_track_speed odo_v_t odo_omega fault virtual_target".split()
SERIES_KEYS = (
    ["t"]
    + TRUTH_KEYS
    + ESTIMATE_KEYS
    + BASELINE_KEYS
    + NAVIGATION_KEYS
    + CONTROL_KEYS
    + SENSOR_KEYS
    + SLIP_KEYS
)
SCALAR_KEYS = ("path_length", "T_N", "T_C", "V_m", "track_width", "start_time")
"""Nominal values (what navigation and control believe); the real robot's are the ``plant_*`` scalars
(scenarios.tolerances.plant_record)."""


@dc.dataclass
class RunResult:
    """A run: its artifact arrays and summary, the reference, and what the robot logged (``sensor_log``:
    the CSV of scenarios/sensor_log.py) with the model its navigation read (``model``)."""

    scenario: Scenario
    seed: int
    arrays: dict
    summary: dict
    reference: Trajectory
    sensor_log: SensorLog | None = None
    model: RobotModel | None = None


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


def check_run_options(
    scenario: Scenario,
    seed: int | None = None,
    duration: float | None = None,
    slip_control: bool | None = None,
    speed_law: str | None = None,
    open_loop: bool | None = None,
) -> None:
    """The overrides of run_scenario (the command line's flags), checked against the scenario before
    anything is built; raises ScenarioError naming the flag (and the parameter)."""
    if not isinstance(scenario, Scenario):
        raise ScenarioError(f"scenario must be a Scenario (load_scenario(...)), got {scenario!r}")
    scenario.validate()  # a Scenario built or changed in Python
    if seed is not None:
        _wrap_value(lambda: require_seed(seed, "--seed"))
    if duration is not None:
        check_duration(scenario, duration)
    for name, value in (("slip_control", slip_control), ("open_loop", open_loop)):
        if value is not None and not isinstance(value, bool):
            raise ScenarioError(f"{name}={value!r} is out of range: allowed True, False or None")
    open_loop = scenario.controller == "feedforward" if open_loop is None else open_loop
    how = "this run is open loop (--open-loop or controller: feedforward)"
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
    if slip_control is not None:
        if scenario.mode != "trajectory":
            raise ScenarioError(
                f"--no-slip-control (slip_control) applies to trajectory scenarios only: {scenario.name!r} "
                f"is mode {scenario.mode} (its speed comes from the speed law)"
            )
        if open_loop:
            raise ScenarioError(f"--no-slip-control (slip_control) applies to the closed loop only: {how}")


def _wrap_value(check):
    try:
        return check()
    except ValueError as e:
        raise ScenarioError(str(e)) from None


def run_scenario(
    scenario: Scenario,
    seed: int | None = None,
    duration: float | None = None,
    slip_control: bool | None = None,
    speed_law: str | None = None,
    open_loop: bool | None = None,
    tolerances: bool = False,
    faults=None,
    localisation: str | None = None,
):
    """Simulate ``scenario`` and collect the run artifact.

    The keyword arguments override the scenario (the command line's --seed, --duration,
    --no-slip-control, --speed-law, --open-loop, --tolerances; None keeps the scenario's). Navigation
    and control read the nominal robot refined by a model (``scenario.belief()``); the plant and sensors
    are the real robot (``scenario.plant_parameters``), whose drawn values the artifact records (``plant_*``
    scalars, the summary's ``plant``). A closed-loop run ends when the controller has finished its
    trajectory (progress Pi at its end) or path (virtual target at its end) plus ``settle_time``, or at
    the duration limit (default: three times the nominal time). Completion is then judged on the true
    pose (judge_completion): ``summary["completed"]``. ``faults``: FaultEvents replacing the scenario's
    ``faults``; ``localisation``: what the follower localises by (--localisation); None keeps them.
    """
    check_run_options(scenario, seed, duration, slip_control, speed_law, open_loop)
    scenario = with_paper_mode(scenario)
    if localisation is not None:
        scenario = dc.replace(scenario, localisation=localisation).validate()
    seed = scenario.seed if seed is None else int(seed)
    speed_law = scenario.speed_law if speed_law is None else speed_law
    slip_control = scenario.slip_control_enabled if slip_control is None else slip_control
    open_loop = scenario.controller == "feedforward" if open_loop is None else open_loop
    rates = scenario.rates()
    belief = scenario.belief()  # what navigation and control read: nominal robot, refined by a model
    robot, nominal_sensors, navigation = belief.robot, belief.sensors, belief.navigation
    plant, sensor_params, deviations = scenario.plant_parameters(seed, tolerances)
    reference, initial_speed = reference_for(scenario)
    pose0 = tuple(scenario.initial_pose)
    faults = scenario.faults if faults is None else faults

    if open_loop:
        start = standstill_for(scenario, initial_speed)
        v_R, v_L = reference.wheel_speeds(robot.track_width)
        built = _wrap_value(
            lambda: build_open_loop_diagram(
                robot,
                sensor_params,
                rates,
                np.column_stack([v_R, v_L]),
                np.column_stack([reference.x, reference.y, reference.phi]),
                seed,
                initial_pose=pose0,
                initial_speed=initial_speed,
                navigation=navigation,
                plant_time_step=scenario.plant_time_step,
                plant=plant,
                start_time=start,
                faults=faults,
                nominal_sensors=nominal_sensors,
                calibration=belief.calibration,
                perturbation_monitor=scenario.perturbation_monitor,
            )
        )
        nominal = reference.duration + start
        path = None
    else:
        control, initial_speed, nominal = closed_loop_settings(scenario, slip_control, speed_law)
        path, start = control.path, control.start_time
        try:
            built = build_closed_loop_diagram(
                robot,
                sensor_params,
                rates,
                navigation,
                control,
                seed,
                initial_pose=pose0,
                initial_speed=initial_speed,
                plant_time_step=scenario.plant_time_step,
                plant=plant,
                faults=faults,
                nominal_sensors=nominal_sensors,
                calibration=belief.calibration,
                perturbation_monitor=scenario.perturbation_monitor,
            )
        except ValueError as e:
            raise ScenarioError(str(e)) from None
    # Open loop: the reference's end; closed loop: a generous limit, cut at completion below.
    limit = end_time(scenario, nominal if open_loop else 3.0 * nominal + scenario.settle_time, duration)
    check_fault_starts(faults, limit)
    simulator = make_simulator(built.diagram, seed, robot.speed_loop_period)
    context = simulator.get_context()
    drain = LogDrain(built.loggers, context, int(math.ceil(limit / rates.T_N)) + 2)
    health = NavigationHealth(built.diagram, context)
    wall_start = time.perf_counter()
    controller_done = None  # when the controller finished its reference (not where the robot is)
    done = None if open_loop else _completion_check(drain, scenario.mode, reference, path)
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
                if controller_done is not None and duration is None and scenario.duration is None:
                    limit = min(limit, controller_done + scenario.settle_time)
    if open_loop and nominal <= limit and health.aborted is None:
        controller_done = nominal
    wall = time.perf_counter() - wall_start

    arrays = collect_arrays(drain.loggers(), context, plant, copy=False)
    record = plant_record(plant, sensor_params)
    n = len(arrays["t"])
    for key in SERIES_KEYS:
        arrays.setdefault(key, np.full(n, np.nan))
    arrays.update(
        path_length=np.array(reference.length if path is None else path.length),
        T_N=np.array(rates.T_N),
        T_C=np.array(rates.T_C),
        V_m=np.array(robot.wheel_speed_limit),
        track_width=np.array(robot.track_width),
        start_time=np.array(start),
        **{f"plant_{key}": np.array(value) for key, value in record.items()},
    )
    # Completion on the true pose against the path followed (closed loop) or the reference (open loop).
    track_x, track_y = (reference.x, reference.y) if path is None else (path.x, path.y)
    judged = judge_completion(
        arrays["t"], arrays["true_x"], arrays["true_y"], track_x, track_y, completion_tolerance(robot)
    )
    travelled = float(np.sum(np.hypot(np.diff(arrays["true_x"]), np.diff(arrays["true_y"]))))
    moved = travelled >= moving_distance(judged["completion_tolerance_m"], float(arrays["path_length"]))
    summary = {
        "scenario": scenario.name,
        "seed": seed,
        "robot": robot.name,
        "mode": scenario.mode,
        "controller": "open-loop feed-forward" if open_loop else "closed loop",
        "slip_control": bool(slip_control) if scenario.mode == "trajectory" and not open_loop else None,
        "speed_law": speed_law if scenario.mode == "max_speed" and not open_loop else None,
        "localisation": None if open_loop else scenario.localisation,
        "sensor_faults": int(np.nansum(arrays["fault"])),
        "sensor_health": health_report(arrays["t"], arrays, SENSOR_CHANNELS),
        "gyro_bias_changes_s": change_times(arrays["t"], arrays["gyro_bias_changes"]),
        "perturbations": perturbation_report(arrays["t"], arrays),
        "faults": [dc.asdict(event) for event in faults],
        "tolerances": bool(tolerances),
        "paper": bool(scenario.paper),
        "model": scenario.model,
        "plant": record,
        "plant_deviations": {key: float(value) for key, value in deviations.items()},
        "path_length_m": float(arrays["path_length"]),
        "duration_s": float(arrays["t"][-1]),
        "standstill_s": float(start),
        "completed": judged["completed"],
        "completion_time_s": judged["completion_time_s"],
        "completion_tolerance_m": judged["completion_tolerance_m"],
        "end_distance_m": judged["end_distance_m"],
        "end_progress_m": judged["end_progress_m"],
        "controller_completion_time_s": controller_done,
        "final_position_error_m": final_position_errors(arrays),
        "reference_final_distance_m": float(
            math.hypot(arrays["true_x"][-1] - reference.x[-1], arrays["true_y"][-1] - reference.y[-1])
        ),
        "travelled_m": travelled,
        "moved": moved,
        "path_error_rms_m": None,
        "path_error_max_m": None,
        "peak_abs_true_alpha_deg": float(np.degrees(np.nanmax(np.abs(moving_alpha(arrays)), initial=0.0))),
        "peak_abs_slip_ratio": float(
            np.nanmax(np.abs(np.concatenate([arrays["true_slip_R"], arrays["true_slip_L"]])))
        ),
        "max_abs_wheel_command_m_s": float(np.nanmax(np.abs(np.r_[arrays["cmd_R"], arrays["cmd_L"]]))),
        "min_step_size": float(np.nanmin(arrays["step_size"]))
        if np.isfinite(arrays["step_size"]).any()
        else None,
        "aborted": health.aborted,
        "covariance_min_eigenvalue": health.min_eigenvalue,
        "covariance_max_eigenvalue": health.max_eigenvalue,
        "covariance_max_asymmetry": health.max_asymmetry,
        "wall_time_s": wall,
        # Simulated time over the wall time of the simulation alone (slipnav bench reports the same).
        "realtime_factor": float(arrays["t"][-1] / wall) if wall > 0 else None,
    }
    if path is not None and moved:  # distance to the path's segments until the controller finished
        until = arrays["t"] <= (controller_done if controller_done is not None else np.inf)
        err = judged["distance"][until]
        summary["path_error_rms_m"] = float(np.sqrt(np.mean(err**2)))
        summary["path_error_max_m"] = float(np.max(err))
    log = sensor_log_from_arrays(
        arrays,
        sensor_params.encoder_counts_per_revolution,
        {
            "robot": robot.name,
            "T_N": rates.T_N,
            "T_C": rates.T_C,
            "encoder_counts_per_revolution": sensor_params.encoder_counts_per_revolution,
            "initial_pose": tuple(float(v) for v in pose0),
            "initial_speed": float(initial_speed),
            "start_time": float(start),
            "scenario": scenario.name or "scenario",
            "seed": seed,
        },
    )
    return RunResult(
        scenario=scenario,
        seed=seed,
        arrays=arrays,
        summary=summary,
        reference=reference,
        sensor_log=log,
        model=belief_model(scenario, belief),
    )


def belief_model(scenario: Scenario, belief=None) -> RobotModel:
    """The model the run's navigation and control read (its ``<stem>.model.yaml``): the nominal robot with
    the scenario's overrides and those of its ``model``, the model's calibration and standard errors, the
    periods and the navigation tuning in force."""
    belief = belief or scenario.belief()
    model = belief.model
    read = f" with the model {scenario.model!r}" if model is not None else ""
    return RobotModel(
        robot=scenario.robot,
        description=f"the model scenario {scenario.name!r} believed{read} (written by slipnav run)",
        robot_overrides={**scenario.robot_overrides, **(model.robot_overrides if model else {})},
        sensor_overrides={**scenario.sensor_overrides, **(model.sensor_overrides if model else {})},
        calibration=belief.calibration,
        T_N=scenario.T_N,
        T_C=scenario.T_C,
        navigation=belief.navigation,
        standard_errors=dict(model.standard_errors) if model else {},
    )


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


class LogDrain:
    """Moves the samples of a diagram's shared log (open_loop.add_loggers: one VectorLogSink) into
    preallocated arrays after every simulator step and clears the sink, so that a run's memory is one
    float64 per logged channel and sample (Drake's log would double its capacity as it grows, and
    collect_arrays copy it). ``loggers()`` gives SignalLog look-alikes over the drained samples.

    Args:
        loggers: the LoggedDiagram's loggers (SignalLog, all on one sink). context: the root context.
        capacity: the number of samples expected (grown by half if exceeded).
    """

    def __init__(self, loggers: dict, context, capacity: int):
        self._signals = loggers
        self._sink = next(iter(loggers.values())).sink
        self._context = context
        rows = max(signal.rows.stop for signal in loggers.values())
        self.buffer, self._t, self.n = np.empty((rows, capacity)), np.empty(capacity), 0

    @property
    def t(self) -> np.ndarray:
        return self._t[: self.n]

    def signal(self, name: str) -> np.ndarray:
        """The drained rows of one signal (a view: rows x samples)."""
        return self.buffer[self._signals[name].rows, : self.n]

    def drain(self) -> slice:
        """Take the sink's new samples; returns their slice in the drained arrays."""
        log = self._sink.FindMutableLog(self._context)
        m = log.num_samples()
        if self.n + m > self._t.size:
            grown = max(self.n + m, self._t.size + self._t.size // 2)
            buffer, times = np.empty((self.buffer.shape[0], grown)), np.empty(grown)
            buffer[:, : self.n], times[: self.n] = self.buffer[:, : self.n], self._t[: self.n]
            self.buffer, self._t = buffer, times
        self.buffer[:, self.n : self.n + m] = log.data()
        self._t[self.n : self.n + m] = log.sample_times()
        log.Clear()
        self.n += m
        return slice(self.n - m, self.n)

    def loggers(self) -> dict:
        """SignalLog look-alikes (``FindLog(context).data()``, ``.sample_times()``) over the drained
        samples, for collect_arrays (views, no copies)."""
        return {name: _DrainedSignal(self, name) for name in self._signals}


class _DrainedSignal:
    def __init__(self, drain: LogDrain, name: str):
        self._drain, self._name = drain, name

    def FindLog(self, context):  # noqa: N802 (the VectorLogSink API)
        return _DrainedRows(self._drain.signal(self._name), self._drain.t)


class _DrainedRows:
    def __init__(self, data, times):
        self._data, self._times = data, times

    def data(self):
        return self._data

    def sample_times(self):
        return self._times

    def num_samples(self):
        return len(self._times)


class NavigationHealth:
    """Checks the navigation after every simulator step: the logged estimate (fused pose, mixed estimate)
    of the new samples and the EKF covariance P (the navigation's ``covariance`` output) must be finite;
    records the extreme eigenvalues of P and its largest asymmetry |P - P^T| over the run (P as the steps
    end, every 0.1 s). ``aborted``: None, or why the run was stopped (the first non-finite value)."""

    ESTIMATE_SIGNALS = ("nav_pose", "nav_mixed_estimate")

    def __init__(self, diagram, context):
        self.aborted = None
        self.min_eigenvalue = self.max_eigenvalue = self.max_asymmetry = None
        try:
            nav = diagram.GetSubsystemByName("navigation")
        except RuntimeError:
            self._port = None  # no navigation in this diagram
            return
        self._port, self._context = nav.GetOutputPort("covariance"), nav.GetMyContextFromRoot(context)

    def check(self, drain: LogDrain, new: slice) -> str | None:
        """Check the samples ``new`` and the current P; returns (and keeps) the reason to stop, else
        None."""
        if self._port is None or self.aborted is not None:
            return self.aborted
        for name in self.ESTIMATE_SIGNALS:
            rows = drain.signal(name)[:, new]
            bad = np.argwhere(~np.isfinite(rows))
            if len(bad):
                row, k = bad[0]
                self.aborted = (
                    f"the navigation estimate became non-finite at t = {drain.t[new][k]:.3f} s "
                    f"({name} row {row} = {rows[row, k]})"
                )
                return self.aborted
        P = self._port.Eval(self._context).reshape(5, 5)
        if not np.all(np.isfinite(P)):
            t = drain.t[new][-1] if new.stop > new.start else math.nan
            self.aborted = f"the EKF covariance P became non-finite by t = {t:.3f} s"
            return self.aborted
        eigenvalues = np.linalg.eigvalsh(0.5 * (P + P.T))
        asymmetry = float(np.max(np.abs(P - P.T)))
        self.min_eigenvalue = _extreme(min, self.min_eigenvalue, float(eigenvalues[0]))
        self.max_eigenvalue = _extreme(max, self.max_eigenvalue, float(eigenvalues[-1]))
        self.max_asymmetry = _extreme(max, self.max_asymmetry, asymmetry)
        return None


def _extreme(pick, current, value):
    return value if current is None else pick(current, value)


def path_projection(x, y, path_x, path_y, block: int = 256, margin: float = 0.2):
    """Distance of each point (x, y) from the polyline (path_x, path_y), measured to its segments (the
    foot of the perpendicular, or a segment's end), and the arc length of that foot: (distance, s).

    The search is local: the points are taken as a track in time order, in blocks of ``block``; a block
    searches only the segments from ``margin`` m behind the previous block's foot to ``margin`` m plus
    twice the distance the block's points travel ahead of it. Memory stays O(block x window), and a path
    that passes its start again (a circle) is not matched to its end too early.
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    px, py = np.asarray(path_x, float), np.asarray(path_y, float)
    if len(px) < 2:
        raise ValueError("path_projection needs a polyline of at least 2 points")
    seg_len = np.hypot(np.diff(px), np.diff(py))
    s_vertex = np.concatenate([[0.0], np.cumsum(seg_len)])
    distance, progress = np.empty(len(x)), np.empty(len(x))
    s_prev = 0.0
    for i in range(0, len(x), block):
        bx, by = x[i : i + block], y[i : i + block]
        travelled = float(np.sum(np.hypot(np.diff(bx), np.diff(by)))) if len(bx) > 1 else 0.0
        lo = max(int(np.searchsorted(s_vertex, s_prev - margin, side="right")) - 1, 0)
        hi = min(int(np.searchsorted(s_vertex, s_prev + margin + 2.0 * travelled, side="left")) + 1, len(px))
        hi = max(hi, lo + 2)
        ax, ay = px[lo : hi - 1], py[lo : hi - 1]  # segment starts
        dx, dy, length = np.diff(px[lo:hi]), np.diff(py[lo:hi]), seg_len[lo : hi - 1]
        # Foot of the perpendicular as a fraction of each segment, clipped to the segment.
        rx, ry = bx[:, None] - ax[None, :], by[:, None] - ay[None, :]
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(length > 0.0, (rx * dx + ry * dy) / (length * length), 0.0)
        u = np.clip(u, 0.0, 1.0)
        d2 = (rx - u * dx) ** 2 + (ry - u * dy) ** 2
        j = np.argmin(d2, axis=1)
        rows = np.arange(len(bx))
        distance[i : i + block] = np.sqrt(d2[rows, j])
        progress[i : i + block] = s_vertex[lo + j] + u[rows, j] * length[j]
        s_prev = float(progress[i + len(bx) - 1])
    return distance, progress


def path_distance(x, y, path: Path) -> np.ndarray:
    """Distance of each point (x, y) of a track from the path polyline's segments (see path_projection)."""
    return path_projection(x, y, path.x, path.y)[0]


def moving_distance(tolerance: float, path_length: float) -> float:
    """The true distance a run must travel to count as moved (m): the completion tolerance, or half the
    path where that is shorter. A robot that stayed within it of its start (no grip, a wheel held) has
    no path error to report: its distance from the path is the start's, a few nanometres."""
    return min(tolerance, 0.5 * path_length)


def completion_tolerance(robot: RobotParameters) -> float:
    """How close to the end of its path the robot must really be to count as arrived (m):
    max(0.05 m, 2 track widths) (Tinyphoon 0.136 m, Kurt3D 0.8 m)."""
    return max(0.05, 2.0 * robot.track_width)


def judge_completion(t, x, y, path_x, path_y, tolerance: float) -> dict:
    """Completion judged on the true track: the robot reached the end of the path (polyline path_x,
    path_y) when its true position came within ``tolerance`` of the path's end point with its
    along-path progress within ``tolerance`` of the path's length; ``completion_time_s`` is the first
    such sample (None if never). ``end_distance_m`` is where it finally stopped (an overshoot shows there)."""
    distance, progress = path_projection(x, y, path_x, path_y)
    length = float(np.sum(np.hypot(np.diff(path_x), np.diff(path_y))))
    to_end = np.hypot(np.asarray(x) - path_x[-1], np.asarray(y) - path_y[-1])
    arrived = np.flatnonzero((to_end <= tolerance) & (progress >= length - tolerance))
    completed = len(arrived) > 0
    completion = float(t[arrived[0]]) if completed else None
    return {
        "completed": completed,
        "completion_time_s": completion,
        "completion_tolerance_m": float(tolerance),
        "end_distance_m": float(to_end[-1]),
        "end_progress_m": float(progress[-1]),
        "distance": distance,
    }


def final_position_errors(arrays) -> dict:
    """Distance between each estimate's final position and the true one (None where not estimated)."""
    out = {}
    for label, prefix in ESTIMATES:
        d = final_position_error(arrays, prefix)
        out[label] = d if math.isfinite(d) else None
    return out


def collect_arrays(loggers, context, robot: RobotParameters, copy: bool = True) -> dict:
    """Artifact arrays from the loggers of a diagram (every logger publishes on the T_N grid). The wheel
    speeds, angles and tyre slips are computed from the logged plant state (systems.plant.tyre_slip).
    ``copy=False``: the arrays are views of the loggers' data where they can be (LogDrain's own arrays;
    a Drake log's data lives only as long as its context)."""
    logs = {name: logger.FindLog(context) for name, logger in loggers.items()}
    t = logs["state"].sample_times()
    n = len(t)

    def data(name):
        d = logs[name].data()
        if d.shape[1] != n:
            raise RuntimeError(f"logger {name} has {d.shape[1]} samples, state has {n}")
        return d.copy() if copy else d  # the artifact's rows are views of this block

    x = data("state")
    a = {"t": t.copy() if copy else t}
    for i, key in enumerate(["true_x", "true_y", "true_phi", "true_v_t", "true_v_n", "true_omega"]):
        a[key] = x[i]
    a["true_alpha"] = np.arctan2(a["true_v_n"], a["true_v_t"])
    a["true_wheel_R"], a["true_wheel_L"] = robot.radius_R * x[8], robot.radius_L * x[9]
    a["true_theta_R"], a["true_theta_L"] = x[6], x[7]
    slip = np.empty((n, 4))
    for k in range(n):  # row by row: no list of n Python lists
        slip[k] = tyre_slip(x[:, k], robot)
    a["true_slip_R"], a["true_slip_L"] = slip[:, 0], slip[:, 1]
    acc = data("accelerometers")
    for i, key in enumerate(["meas_a_t1", "meas_a_n1", "meas_a_t2", "meas_a_n2"]):
        a[key] = acc[i]
    a["meas_gyro"] = data("gyro")[0]
    enc = data("encoders")
    a["meas_enc_R"], a["meas_enc_L"] = enc[0], enc[1]
    a["true_gyro_bias"] = data("gyro_bias")[0]
    cmd = data("command")
    a["cmd_R"], a["cmd_L"] = cmd[0], cmd[1]
    for key, name in (
        ("V1", "V1"),
        ("step_size", "step_size"),
        ("progress", "progress"),
        ("virtual_target", "virtual_target"),
    ):
        if name in logs:
            a[key] = data(name)[0]
    ref = data("reference_pose")
    a["ref_x"], a["ref_y"], a["ref_phi"] = ref[0], ref[1], ref[2]
    if "nav_pose" in logs:
        collect_navigation(a, data)
    collect_perturbations(a, logs, data)
    if "motor_currents" in logs:
        currents = data("motor_currents")
        a["meas_current_R"], a["meas_current_L"] = currents[0], currents[1]
    return a


def collect_perturbations(a: dict, logs, data) -> None:
    """The perturbation monitor's artifact keys (``perturbation_<channel>``: its flags and force
    residuals) from its loggers ``perturbation`` and ``force_residual``, where ``logs`` has them."""
    if "perturbation" in logs:
        flags = data("perturbation")
        for i, channel in enumerate(PERTURBATION_CHANNELS):
            a[f"perturbation_{channel}"] = flags[i]
    if "force_residual" in logs:
        forces = data("force_residual")
        for i, channel in enumerate(FORCE_CHANNELS):
            a[f"perturbation_{channel}"] = forces[i]


def collect_navigation(a: dict, data) -> None:
    """The navigation keys of the artifact from the navigation diagram's loggers (``data(name)``: the
    logger's rows x samples; the keys are views of its rows)."""
    for prefix, name in (("est", "nav_pose"), ("odo", "nav_odometry_pose"), ("gyro", "nav_gyrodometry_pose")):
        pose = data(name)
        a[f"{prefix}_x"], a[f"{prefix}_y"], a[f"{prefix}_phi"] = pose[0], pose[1], pose[2]
    mixed = data("nav_mixed_estimate")
    for i, key in enumerate(["est_v_t", "est_v_n", "est_omega", "est_a_t", "est_a_n"]):
        a[key] = mixed[i]
    a["est_alpha"] = data("nav_side_slip_angle")[0]
    a["est_track_speed"] = data("nav_track_speed")[0]
    a["C1"] = data("nav_C1")[0]
    a["slide_onset"] = data("nav_slide_onset")[0]
    c23 = data("nav_C2_C3")
    a["C2"], a["C3"] = c23[0], c23[1]
    check = data("nav_tyre_model_check")
    a["tyre_model_weight"], a["free_v_n"] = check[0], check[1]
    a["est_tyre_peak"] = check[3]
    a["delta_v"] = data("nav_delta_v")[0]
    odo = data("nav_odometry")
    a["odo_v_t"], a["odo_omega"] = odo[0], odo[1]
    a["fault"] = np.maximum(data("nav_inertial_fault")[0], data("nav_encoder_fault")[0])
    a["est_gyro_bias"] = data("nav_gyro_bias")[0]
    a["standstill"] = data("nav_standstill")[0]
    accel_bias = data("nav_accelerometer_bias")
    for i, axis in enumerate(("t1", "n1", "t2", "n2")):
        a[f"est_accel_bias_{axis}"] = accel_bias[i]
    health = data("nav_health")
    for i, channel in enumerate(SENSOR_CHANNELS):
        a[f"health_{channel}"] = health[i]
    calibration = data("nav_yaw_calibration")
    a["est_gyro_bias_std"] = calibration[2]
    a["est_radius_difference"], a["est_radius_difference_std"] = calibration[1], calibration[3]
    a["gyro_bias_changes"] = calibration[6]


def change_times(t, counts) -> list:
    """The times (s) at which a cumulative count of detected changes (``gyro_bias_changes``) grows."""
    counts = np.nan_to_num(np.asarray(counts, float))
    grown = np.flatnonzero(np.diff(counts, prepend=counts[:1]) > 0)
    return [float(t[k]) for k in grown]


def artifact_stem(result: RunResult) -> str:
    """File stem of a run's artifacts: ``<scenario>-seed<N>`` plus the switches that changed what ran,
    ``-open-loop``, ``-no-slip-control``, ``-speed-law-constant``, ``-tolerances``,
    ``-localised-by-<source>``, ``-paper``, ``-model-<model file stem>`` (README: Run artifacts)."""
    s = result.summary
    stem = f"{s['scenario'] or 'scenario'}-seed{s['seed']}"
    if s["controller"] != "closed loop":
        stem += "-open-loop"
    if s["slip_control"] is False:
        stem += "-no-slip-control"
    if s["speed_law"] == "constant":
        stem += "-speed-law-constant"
    if s.get("tolerances"):
        stem += "-tolerances"
    if s.get("localisation") not in (None, "fused"):
        stem += f"-localised-by-{s['localisation']}"
    if s.get("paper"):
        stem += "-paper"
    if s.get("model"):
        stem += f"-model-{model_stem(s['model'])}"
    return stem


def model_stem(path) -> str:
    """``runs/tinyphoon-seed3.calibrated.model.yaml`` -> ``tinyphoon-seed3.calibrated``."""
    name = FilePath(path).name
    for suffix in (".yaml", ".yml", ".model"):
        name = name.removesuffix(suffix)
    return name or "model"


FIGURE_SAMPLES = 150_000
"""Most samples a figure plots (300 s at T_N = 2 ms); a longer run's figures plot every k-th sample."""


def figure_arrays(arrays: dict, limit: int = FIGURE_SAMPLES) -> dict:
    """The arrays the figures plot: every sample up to ``limit`` samples, else every k-th sample with
    k = ceil(samples / limit) (matplotlib would otherwise hold millions of points per line for an
    hour's run; the npz keeps every sample)."""
    n = len(arrays["t"])
    stride = -(-n // limit)
    if stride == 1:
        return arrays
    return {key: v[::stride] if np.ndim(v) == 1 and len(v) == n else v for key, v in arrays.items()}


def check_output_directory(out_dir) -> FilePath:
    """Create ``out_dir`` if needed and prove it writable (before a simulation, so that a bad --out
    fails at once); raises ScenarioError naming --out."""
    out = FilePath(out_dir)
    if out.exists() and not out.is_dir():
        raise ScenarioError(f"--out={str(out_dir)!r} is a file: allowed a directory (created if missing)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe, name = tempfile.mkstemp(dir=out, prefix=".slipnav-probe-")
        os.close(probe)
        os.unlink(name)
    except OSError as e:
        reason = e.strerror or str(e)
        raise ScenarioError(f"--out={str(out_dir)!r} is not a writable directory: {reason}") from None
    return out


def write_artifacts(result: RunResult, out_dir, figures: bool = True) -> list[FilePath]:
    """Write ``<stem>.npz``, ``<stem>.sensors.csv`` (the sensor log), ``<stem>.model.yaml`` (the model
    navigation read), the figures and ``<stem>.summary.json`` (stem: artifact_stem) into ``out_dir``;
    returns the written paths.

    Atomic: everything is first written into a temporary folder inside ``out_dir``, then renamed into
    place (``os.replace``) with Ctrl-C deferred, the summary last. An interruption or error while
    writing leaves no new file and the previous run's files untouched.
    """
    from slipnav.scenarios.plots import write_figures

    out = check_output_directory(out_dir)
    stem = artifact_stem(result)
    staging = FilePath(tempfile.mkdtemp(dir=out, prefix=f".{stem}.partial-"))
    try:
        np.savez(staging / f"{stem}.npz", **{k: np.asarray(v, dtype=float) for k, v in result.arrays.items()})
        staged = [staging / f"{stem}.npz"]
        if result.sensor_log is not None:
            staged.append(staging / f"{stem}.sensors.csv")
            with open(staged[-1], "w") as handle:  # in pieces: a long run's text never whole in memory
                handle.writelines(sensor_log_chunks(result.sensor_log))
        if result.model is not None:
            staged.append(staging / f"{stem}.model.yaml")
            staged[-1].write_text(model_text(result.model))
        if figures:
            staged += write_figures(figure_arrays(result.arrays), result.reference, staging, stem)
        return _publish(staging, staged, stem, result.summary, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _publish(staging, staged: list, stem: str, summary_data: dict, out: FilePath) -> list[FilePath]:
    """Write the summary into ``staging`` and move every staged file into ``out``, the summary last (a
    summary means the files are complete), with Ctrl-C deferred."""
    summary = staging / f"{stem}.summary.json"
    summary.write_text(json.dumps(summary_data, indent=2) + "\n")
    staged = [*staged, summary]
    with deferred_interrupt():
        written = []
        for path in staged:
            os.replace(path, out / path.name)
            written.append(out / path.name)
    return written
