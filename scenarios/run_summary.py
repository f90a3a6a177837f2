"""What a run records besides its arrays: the summary JSON (docs/artifacts.md), the sensor log of what the
robot read and the model its navigation believed."""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from slipnav.scenarios.completion import completion_tolerance, judge_completion, moving_distance
from slipnav.scenarios.config import Scenario
from slipnav.scenarios.metrics import ESTIMATES, final_position_error, moving_alpha, position_errors
from slipnav.scenarios.model import RobotModel
from slipnav.scenarios.navigation_health import NavigationHealth
from slipnav.scenarios.run_plan import RunPlan
from slipnav.scenarios.sensor_log import SensorLog, sensor_log_from_arrays
from slipnav.scenarios.trajectories import (
    Path,
)
from slipnav.systems.health import health_report
from slipnav.systems.health.perturbation import perturbation_report
from slipnav.systems.robot.faults import SENSOR_CHANNELS


def final_position_errors(arrays) -> dict:
    """Distance between each estimate's final position and the true one (None where not estimated)."""
    out = {}
    for label, prefix in ESTIMATES:
        d = final_position_error(arrays, prefix)
        out[label] = d if math.isfinite(d) else None
    return out


POSITION_ERROR_KEYS = {
    "final_position_error_m": "final",
    "rms_position_error_m": "rms",
    "max_position_error_m": "max",
    "max_position_error_time_s": "max_time_s",
}
"""Summary key -> position_errors' figure: each key holds {fused, odometry, gyrodometry}."""


def position_error_summary(arrays) -> dict:
    """The summary's position errors (POSITION_ERROR_KEYS): each estimate's final error, its RMS and
    maximum along the run (m; metrics.position_errors) and when the maximum occurred (s); None where not
    estimated or without truth."""
    errors = {label: position_errors(arrays, prefix) for label, prefix in ESTIMATES}
    return {
        key: {label: _finite_or_none(errors[label][figure]) for label, _ in ESTIMATES}
        for key, figure in POSITION_ERROR_KEYS.items()
    }


def _finite_or_none(value: float):
    return value if math.isfinite(value) else None


def change_times(t, counts) -> list:
    """The times (s) at which a cumulative count of detected changes (``gyro_bias_changes``) grows."""
    counts = np.nan_to_num(np.asarray(counts, float))
    grown = np.flatnonzero(np.diff(counts, prepend=counts[:1]) > 0)
    return [float(t[k]) for k in grown]


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


def run_summary(
    plan: RunPlan,
    arrays: dict,
    record: dict,
    path: Path | None,
    start: float,
    controller_done: float | None,
    health: NavigationHealth,
    wall: float,
) -> dict:
    """The summary JSON of a run (docs/artifacts.md) from its arrays, the real robot's ``record``
    (plant_record), the path the closed loop followed (None: open loop), the standstill ``start`` (s),
    when the controller finished (None: never), the navigation's health and the simulation's wall time.
    Completion is judged on the true pose (judge_completion)."""
    scenario, reference, robot, open_loop = plan.scenario, plan.reference, plan.belief.robot, plan.open_loop
    seed, faults, deviations = plan.truth.seed, plan.truth.faults, plan.deviations
    slip_control, speed_law, tolerances = plan.slip_control, plan.speed_law, plan.tolerances
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
        **position_error_summary(arrays),
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
    return summary


def run_sensor_log(plan: RunPlan, arrays: dict, initial_speed: float, start: float) -> SensorLog:
    """The sensor log of a run (scenarios/sensor_log.py): what the robot read, with the header a replay
    starts from (``initial_speed``: the robot's at t = 0; ``start``: the standstill, s)."""
    scenario, robot, rates, sensor_params = plan.scenario, plan.belief.robot, plan.rates, plan.truth.sensors
    seed, pose0 = plan.truth.seed, plan.truth.initial_pose
    return sensor_log_from_arrays(
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
