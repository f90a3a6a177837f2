"""``slipnav replay LOG.csv [--model MODEL.yaml] [--out DIR]``: the navigation alone on a sensor log.

The log's rows (scenarios/sensor_log.py) drive the navigation in place of the plant and its sensors, by
one of two engines that give the same arrays bit for bit (scenarios/replay_engines.py): ``plain``, the
default, steps the navigation's pure functions row by row; ``diagram`` runs the navigation diagram fed by
a log source (diagrams/replay.py). The model (scenarios/model.py) is what the navigation believes. The
result is a run artifact with the same keys (docs/artifacts.md: Replay): the navigation keys, ``meas_*``
(``meas_current_*`` from ``cur_*``) from the log, ``cmd_*`` and ``true_*`` where the log has those
columns (NaN otherwise), and a summary that compares with the truth only where the log has it.
Replaying the sensor log of a ``slipnav run`` with the model it wrote reproduces the run's estimates bit
for bit.
"""

from __future__ import annotations

import dataclasses as dc
import math
import shutil
import tempfile
import time
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios.artifact_arrays import SERIES_KEYS
from slipnav.scenarios.artifacts import check_output_directory, publish_artifacts
from slipnav.scenarios.config import ScenarioError
from slipnav.scenarios.interrupt import deferred_interrupt
from slipnav.scenarios.model import ModelError, RobotModel, load_model
from slipnav.scenarios.progress import TaskProgress
from slipnav.scenarios.replay_engines import start_replay
from slipnav.scenarios.run_summary import POSITION_ERROR_KEYS, position_error_summary
from slipnav.scenarios.sensor_log import SensorLog, SensorLogError, read_metadata, read_sensor_log
from slipnav.systems.checks import require_finite
from slipnav.systems.health.perturbation import perturbation_report
from slipnav.systems.navigation.parameters import (
    NavigationBelief,
    NavigationInitialState,
    NavigationParameters,
)


@dc.dataclass
class ReplayResult:
    name: str
    arrays: dict
    summary: dict


def log_name(path) -> str:
    """The replay's name from the log's file name: ``corner-seed0.sensors.csv`` -> ``corner-seed0``."""
    name = FilePath(path).name
    for suffix in (".csv", ".sensors"):
        name = name.removesuffix(suffix)
    return name or "log"


def companion_model(path) -> FilePath | None:
    """The ``<name>.model.yaml`` that ``slipnav run`` writes beside ``<name>.sensors.csv``, if present."""
    candidate = FilePath(path).with_name(f"{log_name(path)}.model.yaml")
    return candidate if candidate.is_file() else None


def resolve_model(log_path, model_path=None, robot: str | None = None) -> tuple[RobotModel, str]:
    """(model, description): ``model_path``, else the log's companion model, else the nominal model of
    the log's ``# robot:`` (``robot``, default tinyphoon)."""
    path = model_path if model_path is not None else companion_model(log_path)
    if path is not None:
        return load_model(path), str(path)
    name = robot or "tinyphoon"
    model = RobotModel(robot=name)
    model.validate()
    return model, f"nominal {name}"


def initial_state(log: SensorLog) -> NavigationInitialState:
    """The navigation's initial state: the log's ``# initial_pose`` / ``# initial_speed``, else the truth
    of its first row, else at rest at the origin."""
    pose = log.metadata.get("initial_pose")
    if pose is None and log.has_truth:
        pose = tuple(float(log.columns[c][0]) for c in ("true_x", "true_y", "true_phi"))
    speed = log.metadata.get("initial_speed")
    if speed is None and "true_v_t" in log.columns and math.isfinite(log.columns["true_v_t"][0]):
        speed = float(log.columns["true_v_t"][0])
    return NavigationInitialState(speed=float(speed or 0.0), pose=tuple(pose or (0.0, 0.0, 0.0)))


def check_counts(log: SensorLog, model: RobotModel) -> int:
    """Encoder counts per revolution: the model's, which the log's metadata (if any) must match."""
    counts = model.sensor_parameters().encoder_counts_per_revolution
    logged = log.metadata.get("encoder_counts_per_revolution")
    if logged is not None and logged != counts:
        raise SensorLogError(
            f"sensor log: metadata encoder_counts_per_revolution={logged} differs from the model's {counts} "
            "(sensor_overrides.encoder_counts_per_revolution): allowed the same encoder resolution"
        )
    return counts


def replay_log(
    log: SensorLog, model: RobotModel, name: str = "log", navigation=None, engine: str = "plain"
) -> ReplayResult:
    """Run the navigation on ``log`` with ``model``'s belief; returns arrays and summary.

    ``navigation``: NavigationParameters (default: the model's tuning over the defaults).
    ``engine``: ``plain`` (the plain sequential loop) or ``diagram`` (the navigation diagram in a Drake
    Simulator), scenarios/replay_engines.py: the same arrays bit for bit.
    """
    rates = model.rates()
    robot = model.robot_parameters()
    check_log_metadata(log, model, name)
    counts = check_counts(log, model)
    if navigation is None:
        navigation = model.navigation_over(NavigationParameters())
    belief = NavigationBelief.of_robot(
        navigation, robot, rates, initial_state(log), model.sensor_parameters(), model.calibration
    )
    acc, gyro, enc = log.accelerometers, log.gyro, log.encoder_angles(counts)
    replay = start_replay(engine, belief, acc, gyro, enc, log.currents, log.commands)
    end = (len(log) - 1) * rates.T_N
    wall_start = time.perf_counter()
    with deferred_interrupt() as pending, TaskProgress(end, f"slipnav: replaying {name}", "s") as progress:
        t = 0.0
        while t < end - 1e-12:
            t = min(t + 0.1, end)
            replay.advance_to(t)
            progress.update(t)
            pending.raise_if_interrupted()
    wall = time.perf_counter() - wall_start
    a = {"t": log.t.copy()}
    a.update(replay.arrays())
    for i, key in enumerate(("meas_a_t1", "meas_a_n1", "meas_a_t2", "meas_a_n2")):
        a[key] = acc[:, i].copy()
    a["meas_gyro"] = gyro.copy()
    a["meas_enc_R"], a["meas_enc_L"] = enc[:, 0].copy(), enc[:, 1].copy()
    if log.currents is not None:
        a["meas_current_R"], a["meas_current_L"] = log.currents[:, 0].copy(), log.currents[:, 1].copy()
    for key in ("cmd_R", "cmd_L", "true_x", "true_y", "true_phi", "true_v_t", "true_v_n", "true_omega"):
        if key in log.columns:
            a[key] = log.columns[key].copy()
    if "true_v_t" in a and "true_v_n" in a:
        a["true_alpha"] = np.arctan2(a["true_v_n"], a["true_v_t"])
    n = len(log)
    for key in SERIES_KEYS:
        a.setdefault(key, np.full(n, np.nan))
    if log.has_truth:
        path_length = float(np.sum(np.hypot(np.diff(a["true_x"]), np.diff(a["true_y"]))))
    else:
        path_length = math.nan
    a.update(
        path_length=np.array(path_length),
        T_N=np.array(rates.T_N),
        T_C=np.array(rates.T_C),
        V_m=np.array(robot.wheel_speed_limit),
        track_width=np.array(robot.track_width),
        start_time=np.array(log.metadata.get("start_time", math.nan)),  # the run's, if the log says
    )
    summary = replay_summary(log, a, name, robot.name, engine, wall)
    if replay.monitored:
        summary["perturbations"] = perturbation_report(a["t"], a)
    return ReplayResult(name=name, arrays=a, summary=summary)


def replay_summary(log: SensorLog, a: dict, name: str, robot: str, engine: str, wall: float) -> dict:
    """The replay's summary (docs/artifacts.md, Replay) of its arrays ``a``, but the perturbations;
    ``wall``: the replay's wall time (s)."""
    path_length = float(a["path_length"])
    if log.has_truth:
        errors = position_error_summary(a)
    else:
        errors = {key: dict.fromkeys(("fused", "odometry", "gyrodometry")) for key in POSITION_ERROR_KEYS}
    return {
        "scenario": name,
        "source": "replay",
        "engine": engine,
        "seed": log.metadata.get("seed"),
        "robot": robot,
        "rows": len(log),
        "has_truth": log.has_truth,
        "sensor_faults": int(np.nansum(a["fault"])),
        "path_length_m": path_length if math.isfinite(path_length) else None,
        "duration_s": float(a["t"][-1] - a["t"][0]),
        **errors,
        "wall_time_s": wall,
        "realtime_factor": float((a["t"][-1] - a["t"][0]) / wall) if wall > 0 else None,
    }


def check_log_metadata(log: SensorLog, model: RobotModel, path) -> None:
    """The log's metadata against the model, by the checks a run's inputs pass: the encoder resolution
    (check_counts), the control period (the model's), the initial speed within the wheel-speed limit V_m
    as the builders' check_records has truth.initial_speed (either way: a real robot's log may start
    reversing); SensorLogError naming the metadata key."""
    check_counts(log, model)
    where = f"sensor log {str(path)!r}: metadata"
    logged = log.metadata.get("T_C")
    if logged is not None and abs(logged - model.T_C) > 1e-12 * model.T_C:
        raise SensorLogError(
            f"{where} T_C={logged!r} s differs from the model's T_C={model.T_C!r} s: allowed the same periods"
        )
    speed = log.metadata.get("initial_speed")
    if speed is not None:
        try:
            limit = model.robot_parameters().wheel_speed_limit
            require_finite("initial_speed", speed, -limit, limit)
        except ValueError as e:
            raise SensorLogError(f"{where} {e} m/s (the model's wheel_speed_limit)") from None


def read_log(log_path, model_path=None) -> tuple[SensorLog, RobotModel, str]:
    """(log, model, the model's description): the model (resolve_model: by the log's metadata where none
    is given) and the log, both checked as a run's inputs are; errors as ScenarioError naming the column
    and row, or the metadata or model key."""
    try:
        if model_path is not None:
            model, described = load_model(model_path), str(model_path)
        else:
            robot = read_metadata(log_path).get("robot")
            model, described = resolve_model(log_path, None, robot)
        log = read_sensor_log(log_path, model.T_N)
        check_log_metadata(log, model, log_path)
    except (SensorLogError, ModelError) as e:
        raise ScenarioError(str(e)) from None
    return log, model, described


def replay_file(log_path, model_path=None, engine: str = "plain") -> ReplayResult:
    """Read the log and its model (read_log) and replay (replay_log, by ``engine``)."""
    log, model, described = read_log(log_path, model_path)
    result = replay_log(log, model, log_name(log_path), engine=engine)
    result.summary["sensor_log"] = str(log_path)
    result.summary["model"] = described
    return result


SENSOR_SERIES = {
    "gyro": "meas_gyro",
    "acc1_t": "meas_a_t1",
    "acc1_n": "meas_a_n1",
    "acc2_t": "meas_a_t2",
    "acc2_n": "meas_a_n2",
    "enc_R": "meas_enc_R",
    "enc_L": "meas_enc_L",
}
"""The log's sensor columns and the replay's arrays of their samples."""


def sensor_columns_without_samples(arrays: dict) -> list[str]:
    """The log's sensor columns that hold no valid sample (every cell nan or empty): the navigation's
    estimates rest on no sample of them."""
    return [column for column, key in SENSOR_SERIES.items() if not np.isfinite(arrays[key]).any()]


def write_replay_artifacts(result: ReplayResult, out_dir, figures: bool = True) -> list[FilePath]:
    """``<name>-replay.npz``, figures (``.path.png``, ``.navigation.png``) and ``<name>-replay.summary.json``
    (last), atomically as artifacts.write_artifacts."""
    from slipnav.scenarios.plots import write_replay_figures

    out = check_output_directory(out_dir)
    stem = f"{result.name}-replay"
    staging = FilePath(tempfile.mkdtemp(dir=out, prefix=f".{stem}.partial-"))
    try:
        np.savez(staging / f"{stem}.npz", **{k: np.asarray(v, dtype=float) for k, v in result.arrays.items()})
        staged = [staging / f"{stem}.npz"]
        if figures:
            staged += write_replay_figures(result.arrays, staging, stem)
        return publish_artifacts(staging, staged, stem, result.summary, out)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
