"""Build, simulate and record a scenario: the run artifact of ../shared/DESIGN.md.

``run_scenario`` returns the artifact arrays and summary; ``write_artifacts`` writes
``DIR/<scenario>.npz``, ``DIR/<scenario>.summary.json`` and the figures.

Every array is logged on the T_N grid by Drake loggers, which publish at t_k before the discrete updates
of t_k: a row holds the true continuous state at t_k and the discrete signals (sensor samples ``meas_*``,
commands) as the blocks updating at t_k read them.
"""

from __future__ import annotations

import dataclasses as dc
import json
import math
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.diagrams.closed_loop import ControlSettings, build_closed_loop_diagram
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios.config import Scenario, ScenarioError
from slipnav.scenarios.metrics import moving_alpha
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
from slipnav.systems.plant import RobotParameters, tyre_slip

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
SCALAR_KEYS = ("path_length", "T_N", "T_C", "V_m", "track_width")
"""Nominal values (what navigation and control believe); the real robot's are the ``plant_*`` scalars
(scenarios.tolerances.plant_record)."""


@dc.dataclass
class RunResult:
    scenario: Scenario
    seed: int
    arrays: dict
    summary: dict
    reference: Trajectory


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
        robot = scenario.robot_parameters()
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
        nominal = path.length / (0.5 * scenario.robot_parameters().wheel_speed_limit)
    else:
        nominal = reference.duration
    control = ControlSettings(
        mode=scenario.mode,
        path=path,
        trajectory=reference,
        follower=scenario.follower,
        step_size=scenario.slip_control,
        slip_control=slip_control,
        speed_law=speed_law,
    )
    return control, initial_speed, nominal


def end_time(scenario: Scenario, nominal: float, duration: float | None) -> float:
    """--duration, else the scenario's duration, else the nominal end plus the settle time."""
    if duration is not None:
        if not (math.isfinite(duration) and duration > 0.0):
            raise ScenarioError(f"--duration={duration!r} is out of range: allowed (0, inf) s")
        return duration
    if scenario.duration is not None:
        return scenario.duration
    return nominal + scenario.settle_time


def run_scenario(
    scenario: Scenario,
    seed: int | None = None,
    duration: float | None = None,
    slip_control: bool | None = None,
    speed_law: str | None = None,
    open_loop: bool | None = None,
    tolerances: bool = False,
):
    """Simulate ``scenario`` and collect the run artifact.

    The keyword arguments override the scenario (the command line's --seed, --duration,
    --no-slip-control, --speed-law, --open-loop, --tolerances). Navigation and control read the nominal
    robot (``scenario.robot_parameters()``); the plant and sensors are the real robot
    (``scenario.plant_parameters``), whose drawn values the artifact records (``plant_*`` scalars, the
    summary's ``plant``). A closed-loop run ends when the trajectory (progress
    Pi reaches its end) or the path (virtual target at its end) is complete plus ``settle_time``, or at
    the duration limit (default: three times the nominal time).
    """
    seed = scenario.seed if seed is None else int(seed)
    if not (0 <= seed < 2**31):
        raise ScenarioError(f"seed={seed!r} is out of range: allowed 0 .. 2**31-1")
    speed_law = scenario.speed_law if speed_law is None else speed_law
    if speed_law not in ("bounded", "constant"):
        raise ScenarioError(f"--speed-law={speed_law!r} is unknown: allowed bounded, constant")
    slip_control = scenario.slip_control_enabled if slip_control is None else slip_control
    open_loop = scenario.controller == "feedforward" if open_loop is None else open_loop
    rates = scenario.rates()
    robot = scenario.robot_parameters()
    plant, sensor_params, deviations = scenario.plant_parameters(seed, tolerances)
    reference, initial_speed = reference_for(scenario)
    pose0 = tuple(scenario.initial_pose)

    if open_loop:
        v_R, v_L = reference.wheel_speeds(robot.track_width)
        built = build_open_loop_diagram(
            robot,
            sensor_params,
            rates,
            np.column_stack([v_R, v_L]),
            np.column_stack([reference.x, reference.y, reference.phi]),
            seed,
            initial_pose=pose0,
            initial_speed=initial_speed,
            navigation=scenario.navigation,
            plant_time_step=scenario.plant_time_step,
            plant=plant,
        )
        nominal = reference.duration
        path = None
    else:
        control, initial_speed, nominal = closed_loop_settings(scenario, slip_control, speed_law)
        path = control.path
        try:
            built = build_closed_loop_diagram(
                robot,
                sensor_params,
                rates,
                scenario.navigation,
                control,
                seed,
                initial_pose=pose0,
                initial_speed=initial_speed,
                plant_time_step=scenario.plant_time_step,
                plant=plant,
            )
        except ValueError as e:
            raise ScenarioError(str(e)) from None
    # Open loop: the reference's end; closed loop: a generous limit, cut at completion below.
    limit = end_time(scenario, nominal if open_loop else 3.0 * nominal + scenario.settle_time, duration)
    simulator = make_simulator(built.diagram, seed, robot.speed_loop_period)
    context = simulator.get_context()
    wall_start = time.perf_counter()
    completion = None
    if open_loop:
        simulator.AdvanceTo(limit)
        completion = reference.duration if reference.duration <= limit else None
    else:
        done = _completion_check(built, context, scenario.mode, reference, path)
        t = 0.0
        while t < limit - 1e-12:
            t = min(t + 0.1, limit)
            simulator.AdvanceTo(t)
            if completion is None:
                completion = done()
                if completion is not None and duration is None and scenario.duration is None:
                    limit = min(limit, completion + scenario.settle_time)
    wall = time.perf_counter() - wall_start

    arrays = collect_arrays(built.loggers, context, plant)
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
        **{f"plant_{key}": np.array(value) for key, value in record.items()},
    )
    summary = {
        "scenario": scenario.name,
        "seed": seed,
        "robot": robot.name,
        "mode": scenario.mode,
        "controller": "open-loop feed-forward" if open_loop else "closed loop",
        "slip_control": bool(slip_control) if scenario.mode == "trajectory" and not open_loop else None,
        "speed_law": speed_law if scenario.mode == "max_speed" and not open_loop else None,
        "sensor_faults": int(np.nansum(arrays["fault"])),
        "tolerances": bool(tolerances),
        "plant": record,
        "plant_deviations": {key: float(value) for key, value in deviations.items()},
        "path_length_m": float(arrays["path_length"]),
        "duration_s": float(arrays["t"][-1]),
        "completion_time_s": completion,
        "final_position_error_m": final_position_errors(arrays),
        "reference_final_distance_m": float(
            math.hypot(arrays["true_x"][-1] - reference.x[-1], arrays["true_y"][-1] - reference.y[-1])
        ),
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
        "wall_time_s": wall,
        "realtime_factor": float(arrays["t"][-1] / wall) if wall > 0 else None,
    }
    if path is not None:  # until completion: the robot's braking after the end is not tracking
        until = arrays["t"] <= (completion if completion is not None else np.inf)
        err = path_distance(arrays["true_x"][until], arrays["true_y"][until], path)
        summary["path_error_rms_m"] = float(np.sqrt(np.mean(err**2)))
        summary["path_error_max_m"] = float(np.max(err))
    return RunResult(scenario=scenario, seed=seed, arrays=arrays, summary=summary, reference=reference)


def _completion_check(built, context, mode, reference, path):
    """A function returning the completion time once the reference is finished, else None."""
    if mode == "trajectory":
        logger, end = built.loggers["progress"], reference.num_samples - 1
    else:
        logger, end = built.loggers["virtual_target"], path.length - 1e-9

    def done():
        log = logger.FindLog(context)
        values = log.data()[0]
        hits = np.flatnonzero(values >= end)
        return float(log.sample_times()[hits[0]]) if len(hits) else None

    return done


def path_distance(x, y, path: Path, chunk: int = 512) -> np.ndarray:
    """Distance of each point (x, y) from the path polyline's nearest vertex (1 mm grid)."""
    px, py = path.x[:, None], path.y[:, None]
    out = np.empty(len(x))
    for i in range(0, len(x), chunk):
        dx = px - x[None, i : i + chunk]
        dy = py - y[None, i : i + chunk]
        out[i : i + chunk] = np.sqrt(np.min(dx * dx + dy * dy, axis=0))
    return out


def final_position_errors(arrays) -> dict:
    """Distance between each estimate's final position and the true one (None where not estimated)."""
    out = {}
    for label, prefix in (("fused", "est"), ("odometry", "odo"), ("gyrodometry", "gyro")):
        dx = arrays[f"{prefix}_x"][-1] - arrays["true_x"][-1]
        dy = arrays[f"{prefix}_y"][-1] - arrays["true_y"][-1]
        d = math.hypot(dx, dy)
        out[label] = d if math.isfinite(d) else None
    return out


def collect_arrays(loggers, context, robot: RobotParameters) -> dict:
    """Artifact arrays from the loggers of a diagram (every logger publishes on the T_N grid). The wheel
    speeds, angles and tyre slips are computed from the logged plant state (systems.plant.tyre_slip)."""
    logs = {name: logger.FindLog(context) for name, logger in loggers.items()}
    t = logs["state"].sample_times()
    n = len(t)

    def data(name):
        d = logs[name].data()
        if d.shape[1] != n:
            raise RuntimeError(f"logger {name} has {d.shape[1]} samples, state has {n}")
        return d

    x = data("state")
    a = {"t": t.copy()}
    for i, key in enumerate(["true_x", "true_y", "true_phi", "true_v_t", "true_v_n", "true_omega"]):
        a[key] = x[i].copy()
    a["true_alpha"] = np.arctan2(a["true_v_n"], a["true_v_t"])
    a["true_wheel_R"], a["true_wheel_L"] = robot.radius_R * x[8], robot.radius_L * x[9]
    a["true_theta_R"], a["true_theta_L"] = x[6].copy(), x[7].copy()
    slip = np.array([tyre_slip(column, robot) for column in x.T]).reshape(-1, 4)
    a["true_slip_R"], a["true_slip_L"] = slip[:, 0].copy(), slip[:, 1].copy()
    acc = data("accelerometers")
    for i, key in enumerate(["meas_a_t1", "meas_a_n1", "meas_a_t2", "meas_a_n2"]):
        a[key] = acc[i].copy()
    a["meas_gyro"] = data("gyro")[0].copy()
    enc = data("encoders")
    a["meas_enc_R"], a["meas_enc_L"] = enc[0].copy(), enc[1].copy()
    cmd = data("command")
    a["cmd_R"], a["cmd_L"] = cmd[0].copy(), cmd[1].copy()
    for key, name in (
        ("V1", "V1"),
        ("step_size", "step_size"),
        ("progress", "progress"),
        ("virtual_target", "virtual_target"),
    ):
        if name in logs:
            a[key] = data(name)[0].copy()
    ref = data("reference_pose")
    a["ref_x"], a["ref_y"], a["ref_phi"] = ref[0].copy(), ref[1].copy(), ref[2].copy()
    if "nav_pose" in logs:
        collect_navigation(a, data)
    return a


def collect_navigation(a: dict, data) -> None:
    """The navigation keys of the artifact from the navigation diagram's loggers."""
    for prefix, name in (("est", "nav_pose"), ("odo", "nav_odometry_pose"), ("gyro", "nav_gyrodometry_pose")):
        pose = data(name)
        a[f"{prefix}_x"], a[f"{prefix}_y"], a[f"{prefix}_phi"] = (
            pose[0].copy(),
            pose[1].copy(),
            pose[2].copy(),
        )
    mixed = data("nav_mixed_estimate")
    for i, key in enumerate(["est_v_t", "est_v_n", "est_omega", "est_a_t", "est_a_n"]):
        a[key] = mixed[i].copy()
    a["est_alpha"] = data("nav_side_slip_angle")[0].copy()
    a["est_track_speed"] = data("nav_track_speed")[0].copy()
    a["C1"] = data("nav_C1")[0].copy()
    c23 = data("nav_C2_C3")
    a["C2"], a["C3"] = c23[0].copy(), c23[1].copy()
    a["delta_v"] = data("nav_delta_v")[0].copy()
    odo = data("nav_odometry")
    a["odo_v_t"], a["odo_omega"] = odo[0].copy(), odo[1].copy()
    a["fault"] = np.maximum(data("nav_inertial_fault")[0], data("nav_encoder_fault")[0])
    a["est_gyro_bias"] = data("nav_gyro_bias")[0].copy()
    calibration = data("nav_yaw_calibration")
    a["est_radius_difference"], a["est_radius_difference_std"] = calibration[1].copy(), calibration[3].copy()


def write_artifacts(result: RunResult, out_dir, figures: bool = True) -> list[FilePath]:
    """Write the npz, the summary JSON and (optionally) the figures; returns the written paths."""
    from slipnav.scenarios.plots import write_figures

    out = FilePath(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    name = result.scenario.name
    npz = out / f"{name}.npz"
    np.savez(npz, **{k: np.asarray(v, dtype=float) for k, v in result.arrays.items()})
    summary = out / f"{name}.summary.json"
    summary.write_text(json.dumps(result.summary, indent=2) + "\n")
    written = [npz, summary]
    if figures:
        written += write_figures(result.arrays, result.reference, out, name)
    return written
