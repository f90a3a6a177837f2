"""``slipnav import phil-turtlebot TRIAL_DIR``: a TurtleBot 2 (Kobuki) trial of the PHIL-MQP recordings,
a folder holding ``kobuki_data_*.csv`` (16-bit wrapping wheel ticks, ~40 Hz, unix time in s and ns),
``rio-data-*.csv`` (navX-MXP IMU read by a RoboRIO, ~50 Hz: raw accelerations in g, raw rates in deg/s,
the RoboRIO's ``fpga time`` in s and the board's ``navx time`` in ms) and a Vicon Nexus export (100 Hz,
rotation vectors in rad and positions in mm per object; the robot is ``phil_turtlebot``).

What the import estimates from the data (scenarios/alignment.py) and reports (``<name>.import.json``):

- each clock is zeroed at its first stamp; the wheel ticks' and the IMU's residual lags behind the Vicon
  clock come from cross-correlating their yaw rates with the Vicon's;
- the gyro's yaw axis and sign (largest correlation), the accelerometer's vertical axis (gravity) and the
  angle of its horizontal axes about it (fit against the Vicon's accelerations; the log uses the nearest
  quarter turn, the board's axes lying along the robot's);
- the Vicon object's rigid offset from the robot (the forward axis's angle and the axle centre's offset);
- the longest time the navX repeats a reading (imu_hold): a model that states no inertial_hold_time gets
  importers.HOLD_MARGIN times it, so that the stuck test does not read the device's own holds as a frozen
  sensor.

The log (scenarios/sensor_log.py) holds every stream on the T_N grid of the model over the interval all
three cover, ``interpolate``d (linear between samples; the wheel ticks between the messages that carry a
new count, alignment.fresh_counts, their common travel averaged over ANGLE_AVERAGE_INTERVALS of them)
or ``hold``. The one IMU fills both accelerometer pairs (acc1 = acc2:
the log requires two); the default model states one set (SensorParameters.accelerometer_sets), so the
second is not read. Encoder counts are whole counts of the model's resolution: the Kobuki's 2578.33 ticks
per revolution are 7735/3, so the default model counts thirds of a tick (7735 per revolution) and the log
holds the ticks times 3. The truth columns and ``<name>.truth.csv`` are the axle centre's pose in the
Vicon's frame.
"""

from __future__ import annotations

import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios import alignment as al
from slipnav.scenarios.importers import (
    RESAMPLING,
    ImportResult,
    LogImportError,
    log_summary,
    read_table,
    resolve_model,
    with_measured_hold,
)
from slipnav.scenarios.model import RobotModel
from slipnav.scenarios.sensor_log import SensorLog
from slipnav.scenarios.turtlebot_model import KOBUKI_TICKS_PER_REVOLUTION, default_model

KOBUKI_TICK_BITS = 16
VICON_OBJECT = "phil_turtlebot"
SMOOTHING = 0.2
"""Window (s) of the Savitzky-Golay derivatives of the truth and of the streams compared with it."""
ACCEL_SMOOTHING = 0.5
"""Window (s) of the accelerations the accelerometer's mapping is fitted on (second derivatives)."""
ANGLE_AVERAGE_INTERVALS = 4
"""``interpolate`` averages the wheels' common travel (theta_R + theta_L)/2 over this many median intervals
between fresh counts (alignment.average_common_travel): the logger stamps a fresh count when
it polls, up to a message interval after the Kobuki counted it, so the speed between two fresh counts is
off by a fraction of itself that the average over four intervals cuts to a quarter (offline: the average
reads two intervals ahead). Their difference, the yaw, stays as interpolated: a spot turn starts and
stops faster than the average, and the gyro's witness would lag it."""
def read_kobuki(path) -> tuple[np.ndarray, np.ndarray, float]:
    """(stamps from the first (s), cumulative ticks (N, 2) right and left from 0, first unix stamp)."""
    d = read_table(FilePath(path), ("left_ticks", "right_ticks", "time_s", "time_ns"))
    if not all(np.all(np.isfinite(v)) for v in d.values()):
        raise LogImportError(f"{str(path)!r}: empty cells; allowed numbers in every row")
    t = (d["time_s"] - d["time_s"][0]) + 1e-9 * (d["time_ns"] - d["time_ns"][0])
    if np.any(np.diff(t) <= 0):
        raise LogImportError(f"{str(path)!r}: columns 'time_s', 'time_ns' do not increase")
    ticks = np.column_stack(
        [al.unwrap_counter(d[c], KOBUKI_TICK_BITS) for c in ("right_ticks", "left_ticks")]
    )
    return t, ticks - ticks[0], float(d["time_s"][0] + 1e-9 * d["time_ns"][0])


def read_navx(path) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, int]:
    """(RoboRIO stamps from the first (s), accelerations (N, 3) m/s^2, rates (N, 3) rad/s, first
    ``fpga time``, rows dropped): a row whose ``navx time`` repeats the previous one is the same sample
    read twice and is dropped."""
    names = [f"raw_accel_{a}" for a in "xyz"] + [f"raw_gyro_{a}" for a in "xyz"] + ["fpga time", "navx time"]
    d = read_table(FilePath(path), names)
    fresh = np.r_[True, np.diff(d["navx time"]) != 0] & np.all(
        np.isfinite(np.column_stack(list(d.values()))), 1
    )
    t = d["fpga time"][fresh]
    if len(t) < 10 or np.any(np.diff(t) <= 0):
        raise LogImportError(f"{str(path)!r}: column 'fpga time' does not increase over 10 rows or more")
    accel = al.GRAVITY * np.column_stack([d[f"raw_accel_{a}"][fresh] for a in "xyz"])
    gyro = np.radians(np.column_stack([d[f"raw_gyro_{a}"][fresh] for a in "xyz"]))
    return t - t[0], accel, gyro, float(t[0]), int(np.sum(~fresh))


def read_vicon(path, name: str = VICON_OBJECT) -> dict:
    """A Vicon Nexus export's object ``name``: ``t`` (s from the first frame), ``rotvec`` (N, 3) rad,
    ``position`` (N, 3) m, ``valid`` (the object seen), ``rate`` (Hz), ``first_frame``."""
    path = FilePath(path)
    try:
        lines = path.read_text(encoding="utf-8-sig").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise LogImportError(f"{str(path)!r} cannot be read: {getattr(e, 'strerror', None) or e}") from None
    if len(lines) < 6 or lines[0].strip().split(",")[0] != "Objects":
        raise LogImportError(f"{str(path)!r} is not a Vicon Nexus export: allowed a first line 'Objects'")
    try:
        rate = float(lines[1].split(",")[0])
    except ValueError:
        raise LogImportError(f"{str(path)!r}, line 2: {lines[1]!r} is not a frame rate") from None
    objects = lines[2].split(",")
    where = [j for j, s in enumerate(objects) if s.strip().endswith(f":{name}") or s.strip() == name]
    if not where:
        raise LogImportError(f"{str(path)!r}: object {name!r} is missing (line 3)")
    j = where[0]
    rows = [line.split(",") for line in lines[5:] if line.strip()]

    def cell(row, k):
        try:
            return float(row[k]) if k < len(row) and row[k].strip() else math.nan
        except ValueError:
            raise LogImportError(f"{str(path)!r}: {row[k]!r} is not a number (frame {row[0]})") from None

    frame = np.array([cell(r, 0) for r in rows])
    values = np.array([[cell(r, j + i) for i in range(6)] for r in rows])
    if len(frame) < 10 or not np.all(np.diff(frame) > 0):
        raise LogImportError(f"{str(path)!r}: the frame numbers do not increase over 10 rows or more")
    valid = np.all(np.isfinite(values), axis=1)
    if valid.sum() < 10:
        raise LogImportError(f"{str(path)!r}: object {name!r} is seen in fewer than 10 frames")
    return {
        "t": (frame - frame[0]) / rate,
        "rotvec": values[:, :3],
        "position": values[:, 3:] / 1000.0,
        "valid": valid,
        "rate": rate,
        "first_frame": int(frame[0]),
    }


def find_trial_files(trial_dir) -> dict:
    """The kobuki, rio and Vicon files of a trial folder (exactly one each)."""
    folder = FilePath(trial_dir)
    if not folder.is_dir():
        raise LogImportError(f"TRIAL_DIR={str(folder)!r} is not a folder: allowed a trial folder (README)")
    found = {}
    for key, pattern in (("kobuki", "kobuki_data_*.csv"), ("rio", "rio-data-*.csv")):
        files = sorted(folder.glob(pattern))
        if len(files) != 1:
            raise LogImportError(f"TRIAL_DIR={str(folder)!r} holds {len(files)} files {pattern}: allowed one")
        found[key] = files[0]
    vicon = []
    for f in sorted(folder.glob("*.csv")):
        with open(f, encoding="utf-8-sig", errors="replace") as handle:
            if handle.readline().split(",")[0].strip() == "Objects":
                vicon.append(f)
    if len(vicon) != 1:
        raise LogImportError(
            f"TRIAL_DIR={str(folder)!r} holds {len(vicon)} Vicon exports (first line 'Objects'): allowed one"
        )
    found["vicon"] = vicon[0]
    return found


def truth_kinematics(vicon: dict) -> dict:
    """The Vicon object's orientation (N, 3, 3), origin (N, 3), yaw (its x axis's, unwrapped) and their
    smoothed derivatives on its frames; unseen frames are bridged (slerp, linear) and ``usable`` is False
    within a smoothing window of them."""
    from scipy.spatial.transform import Rotation, Slerp

    t, valid = vicon["t"], vicon["valid"]
    seen = Rotation.from_rotvec(vicon["rotvec"][valid])
    rotation = Slerp(t[valid], seen)(np.clip(t, t[valid][0], t[valid][-1])).as_matrix()
    position = np.column_stack([np.interp(t, t[valid], vicon["position"][valid, i]) for i in range(3)])
    step = 1.0 / vicon["rate"]
    half = int(round(SMOOTHING / step / 2)) + 1
    usable = np.convolve(~valid, np.ones(2 * half + 1), mode="same") == 0
    usable[:half] = usable[-half:] = False
    yaw = al.heading_of(rotation, 0.0)
    flat = rotation.reshape(-1, 9)
    return {
        "t": t,
        "step": step,
        "rotation": rotation,
        "rotation_rate": al.smooth(flat, step, SMOOTHING, 1).reshape(-1, 3, 3),
        "position": position,
        "velocity": al.smooth(position, step, SMOOTHING, 1),
        "acceleration": al.smooth(position, step, SMOOTHING, 2),
        "yaw_rate": al.smooth(yaw, step, SMOOTHING, 1),
        "usable": usable,
        "valid": valid,
    }


def wheel_kinematics(t, ticks, model: RobotModel, step: float) -> dict:
    """The wheels' mean speed and yaw rate on a uniform grid of the wheels' clock (the ticks interpolated
    between fresh readings, alignment.fresh_counts, smoothed as the truth is)."""
    robot = model.robot_parameters()
    knots_t, knots, interval = al.fresh_counts(t, ticks)
    grid = al.uniform_grid(0.0, float(t[-1]), step)
    angle = al.on_grid(grid, knots_t, knots * (2 * math.pi / KOBUKI_TICKS_PER_REVOLUTION), "interpolate")
    rate = al.smooth(angle, step, SMOOTHING, 1)
    wheel_R, wheel_L = robot.radius_R * rate[:, 0], robot.radius_L * rate[:, 1]
    return {
        "t": grid,
        "speed": 0.5 * (wheel_R + wheel_L),
        "yaw_rate": (wheel_R - wheel_L) / robot.track_width,
        "knots_t": knots_t,
        "knots": knots,
        "interval": interval,
        "fresh_share": float(np.mean(np.r_[True, np.any(np.diff(ticks, axis=0) != 0, axis=1)])),
    }


def angle_average_samples(interval: float, T_N: float) -> int:
    """The odd number of T_N samples the wheel angles are averaged over: ANGLE_AVERAGE_INTERVALS median
    intervals between fresh counts."""
    return int(round(ANGLE_AVERAGE_INTERVALS * interval / T_N)) | 1


def fit_frames(truth: dict, wheels: dict, wheel_lag: float, t_imu, accel, imu_lag: float) -> dict:
    """The truth's rigid offset (alignment.fit_truth_offset), the robot's pose, body velocities and
    accelerations from it, and the accelerometer's mapping (alignment.vertical_axis,
    fit_accelerometer_rotation) on the truth's usable frames."""
    use = truth["usable"]
    speed = np.interp(truth["t"], wheels["t"] - wheel_lag, wheels["speed"])
    offset = al.fit_truth_offset(
        truth["rotation"][use], truth["rotation_rate"][use], truth["velocity"][use], speed[use]
    )
    d = np.asarray(offset["offset"])
    heading, centre = al.truth_pose(truth["rotation"], truth["position"], offset["angle"], d)
    step = truth["step"]
    velocity = (truth["velocity"] + truth["rotation_rate"] @ d)[:, :2]
    c, s = np.cos(heading), np.sin(heading)
    body = {
        "heading": heading,
        "centre": centre,
        "v_t": c * velocity[:, 0] + s * velocity[:, 1],
        "v_n": -s * velocity[:, 0] + c * velocity[:, 1],
        "omega": al.smooth(heading, step, SMOOTHING, 1),
        "height": float(np.median((truth["position"] + truth["rotation"] @ d)[:, 2])),
    }
    vertical, sign = al.vertical_axis(accel)
    i, j = al.horizontal_axes(vertical, sign)
    # The accelerometer against the horizontal offset's point: the markers' rocking about the base (the
    # offset's vertical part) is not in the IMU's readings, and its second derivative is noisy.
    flat = truth["position"] + truth["rotation"] @ np.r_[d[:2], 0.0]
    acc = al.smooth(flat, step, ACCEL_SMOOTHING, 2)[:, :2]
    a_t, a_n = c * acc[:, 0] + s * acc[:, 1], -s * acc[:, 0] + c * acc[:, 1]
    reading = np.column_stack(
        [
            al.smooth(np.interp(truth["t"], t_imu - imu_lag, accel[:, k]), step, ACCEL_SMOOTHING)
            for k in (i, j)
        ]
    )
    w, wd = al.smooth(heading, step, ACCEL_SMOOTHING, 1), al.smooth(heading, step, ACCEL_SMOOTHING, 2)
    rotation = al.fit_accelerometer_rotation(reading[use], a_t[use], a_n[use], w[use], wd[use])
    return {
        "offset": offset,
        "body": body,
        "vertical": (vertical, sign),
        "horizontal": (i, j),
        "rotation": rotation,
    }


def _axis_name(axis: int, sign: float) -> str:
    return ("+" if sign > 0 else "-") + "xyz"[axis]


def accelerometer_mapping(frames: dict) -> tuple[float, str]:
    """(angle used (rad), text): the nearest quarter turn of the fitted angle, as the axes it maps."""
    angle = frames["rotation"]["quarter_turns"] * math.pi / 2
    i, j = frames["horizontal"]
    c, s = round(math.cos(angle)), round(math.sin(angle))
    # a_t = c m_i - s m_j, a_n = s m_i + c m_j
    t_text = _axis_name(i, c) if c else _axis_name(j, -s)
    n_text = _axis_name(i, s) if s else _axis_name(j, c)
    return angle, f"forward = {t_text}, left = {n_text}, up = {_axis_name(*frames['vertical'])}"


def estimate_clocks(files: dict, model: RobotModel) -> dict:
    """Read the three files and estimate the lags, the gyro's axis and the frames (the import's report's
    numbers, with the arrays they came from)."""
    t_enc, ticks, enc_start = read_kobuki(files["kobuki"])
    t_imu, accel, gyro, imu_start, repeated = read_navx(files["rio"])
    vicon = read_vicon(files["vicon"])
    truth = truth_kinematics(vicon)
    wheels = wheel_kinematics(t_enc, ticks, model, truth["step"])
    use = truth["usable"]
    try:
        g = al.select_gyro_axis(truth["t"][use], truth["yaw_rate"][use], t_imu, gyro)
        wheel_lag, wheel_corr = al.estimate_lag(
            truth["t"][use], truth["yaw_rate"][use], wheels["t"], wheels["yaw_rate"]
        )
    except ValueError as e:
        raise LogImportError(f"TRIAL_DIR: {e}") from None
    frames = fit_frames(truth, wheels, wheel_lag, t_imu, accel, g["lag_s"])
    return {
        "t_enc": t_enc,
        "ticks": ticks,
        "t_imu": t_imu,
        "accel": accel,
        "gyro": gyro,
        "vicon": vicon,
        "truth": truth,
        "wheels": wheels,
        "gyro_fit": g,
        "wheel_lag": (wheel_lag, wheel_corr),
        "frames": frames,
        "starts": {"kobuki_unix_s": enc_start, "rio_fpga_s": imu_start, "vicon_frame": vicon["first_frame"]},
        "repeated_imu_rows": repeated,
    }


def imu_hold(est: dict) -> float:
    """The longest time (s) the navX repeats a reading on a channel the log uses (the gyro's yaw axis,
    the accelerometer's horizontal axes), its repeated rows already dropped (read_navx): the device
    reports an unchanged value with a new navx time."""
    i, j = est["frames"]["horizontal"]
    channels = (est["gyro"][:, est["gyro_fit"]["axis"]], est["accel"][:, i], est["accel"][:, j])
    return max(al.longest_hold(est["t_imu"], values) for values in channels)


def build_log(est: dict, model: RobotModel, resample: str, name: str) -> tuple[SensorLog, dict, dict]:
    """The sensor log on the model's T_N grid over the span all streams cover, the truth table on the log's
    clock, and the grid's description."""
    truth, wheels, frames, g = est["truth"], est["wheels"], est["frames"], est["gyro_fit"]
    wheel_lag, imu_lag = est["wheel_lag"][0], g["lag_s"]
    start = max(0.0 - wheel_lag, 0.0 - imu_lag, float(truth["t"][0]))
    end = min(est["t_enc"][-1] - wheel_lag, est["t_imu"][-1] - imu_lag, float(truth["t"][-1]))
    T_N = model.T_N
    grid = al.uniform_grid(start, end, T_N)
    if len(grid) < 2:
        raise LogImportError("TRIAL_DIR: the three logs overlap by less than two T_N samples")
    columns = {"t": T_N * np.arange(len(grid))}
    columns["gyro"] = g["sign"] * al.on_grid(
        grid, est["t_imu"] - imu_lag, est["gyro"][:, g["axis"]], resample
    )
    angle, mapping = accelerometer_mapping(frames)
    i, j = frames["horizontal"]
    body = al.rotate(angle, est["accel"][:, [i, j]])
    acc = al.on_grid(grid, est["t_imu"] - imu_lag, body, resample)
    for k in (1, 2):
        columns[f"acc{k}_t"], columns[f"acc{k}_n"] = acc[:, 0].copy(), acc[:, 1].copy()
    scale = model.sensor_parameters().encoder_counts_per_revolution / KOBUKI_TICKS_PER_REVOLUTION
    if resample == "interpolate":
        ticks = al.on_grid(grid, wheels["knots_t"] - wheel_lag, wheels["knots"], "interpolate")
        ticks = al.average_common_travel(ticks, angle_average_samples(wheels["interval"], T_N))
    else:
        ticks = al.on_grid(grid, est["t_enc"] - wheel_lag, est["ticks"], "hold")
    columns["enc_R"], columns["enc_L"] = np.round(scale * ticks[:, 0]), np.round(scale * ticks[:, 1])
    body, seen = frames["body"], truth["valid"]
    for key, part in (
        ("true_phi", "heading"),
        ("true_v_t", "v_t"),
        ("true_v_n", "v_n"),
        ("true_omega", "omega"),
    ):
        columns[key] = np.interp(grid, truth["t"][seen], body[part][seen])
    for k, key in enumerate(("true_x", "true_y")):
        columns[key] = np.interp(grid, truth["t"][seen], body["centre"][seen, k])
    metadata = {
        "T_N": T_N,
        "T_C": model.T_C,
        "encoder_counts_per_revolution": model.sensor_parameters().encoder_counts_per_revolution,
        "initial_pose": tuple(float(columns[c][0]) for c in ("true_x", "true_y", "true_phi")),
        "initial_speed": float(columns["true_v_t"][0]),
        "scenario": name,
    }
    table = {
        "t": truth["t"] - start,
        "x": np.where(seen, body["centre"][:, 0], np.nan),
        "y": np.where(seen, body["centre"][:, 1], np.nan),
        "yaw": np.where(seen, body["heading"], np.nan),
        "quality": seen.astype(float),
    }
    description = {
        "T_N_s": T_N,
        "rows": len(grid),
        "duration_s": float(grid[-1] - grid[0]),
        "start_on_vicon_clock_s": start,
        "resampling": resample,
        "count_scale": scale,
        "accelerometer_mapping": mapping,
    }
    return SensorLog(columns=columns, metadata=metadata), table, description


def import_trial(trial_dir, model_path=None, resample: str = "interpolate") -> ImportResult:
    """Import one trial folder (the module docstring): the sensor log, the truth table, the model and the
    report of what was estimated."""
    if resample not in RESAMPLING:
        raise LogImportError(f"--resample={resample!r} is unknown: allowed {', '.join(RESAMPLING)}")
    files = find_trial_files(trial_dir)
    model, text = resolve_model(model_path, default_model)
    name = f"phil-turtlebot-{FilePath(trial_dir).resolve().name}"
    est = estimate_clocks(files, model)
    hold = imu_hold(est)
    model, text = with_measured_hold(model, text, "inertial_hold_time", hold, 1.0)
    log, table, grid = build_log(est, model, resample, name)
    g, frames = est["gyro_fit"], est["frames"]
    offset, rotation = frames["offset"], frames["rotation"]
    report = {
        "adapter": "phil-turtlebot",
        "name": name,
        "files": {k: str(v) for k, v in files.items()},
        "truth_source": f"Vicon export {files['vicon']}, the axle centre (truth_offset)",
        "clocks": {
            "kobuki": {
                "first_stamp_unix_s": est["starts"]["kobuki_unix_s"],
                "lag_behind_vicon_s": est["wheel_lag"][0],
                "yaw_rate_correlation": est["wheel_lag"][1],
            },
            "navx": {
                "first_fpga_time_s": est["starts"]["rio_fpga_s"],
                "lag_behind_vicon_s": g["lag_s"],
                "yaw_rate_correlation": g["correlation"],
                "repeated_rows_dropped": est["repeated_imu_rows"],
            },
            "vicon": {"first_frame": est["starts"]["vicon_frame"], "rate_hz": est["vicon"]["rate"]},
            "log_t0_on_vicon_clock_s": grid["start_on_vicon_clock_s"],
        },
        "gyro": {
            "yaw_axis": _axis_name(g["axis"], g["sign"]),
            "axis_correlations": dict(zip("xyz", g["axis_correlations"], strict=True)),
        },
        "accelerometer": {
            "mapping": grid["accelerometer_mapping"],
            "fitted_angle_deg": math.degrees(rotation["angle"]),
            "used_angle_deg": 90.0 * rotation["quarter_turns"],
            "fit_r2": rotation["r2"],
            "lever_m": rotation["lever"],
            "bias_m_s2": rotation["bias"],
            "both_pairs": "the one IMU fills acc1 and acc2 (acc1 = acc2)",
        },
        "imu_stream": {
            "longest_hold_s": hold,
            "model_inertial_hold_time_s": model.sensor_parameters().inertial_hold_time,
        },
        "truth_offset": {
            "forward_axis_in_object_frame_deg": math.degrees(offset["angle"]),
            "axle_centre_in_object_frame_m": offset["offset"],
            "axle_centre_horizontal_distance_m": math.hypot(*offset["offset"][:2]),
            "axle_centre_height_in_vicon_frame_m": frames["body"]["height"],
            "velocity_residual_rms_m_s": offset["rms_m_s"],
            "frames_unseen": int(np.sum(~est["vicon"]["valid"])),
        },
        "encoders": {
            "fresh_message_share": est["wheels"]["fresh_share"],
            "fresh_interval_median_s": est["wheels"]["interval"],
            "angle_average_s": (
                angle_average_samples(est["wheels"]["interval"], model.T_N) * model.T_N
                if resample == "interpolate"
                else 0.0
            ),
            "ticks_per_revolution": KOBUKI_TICKS_PER_REVOLUTION,
            "model_counts_per_revolution": model.sensor_parameters().encoder_counts_per_revolution,
            "counts_per_tick": grid["count_scale"],
        },
        "log": {k: grid[k] for k in ("T_N_s", "rows", "duration_s", "resampling")},
    }
    return ImportResult(name=name, log=log, truth=table, model=model, model_text=text, report=report)


def summary(r: dict) -> str:
    """One line of what the import estimated (slipnav import prints it)."""
    c, o = r["clocks"], r["truth_offset"]
    return log_summary(r) + (
        f"lags behind Vicon: wheels {1000 * c['kobuki']['lag_behind_vicon_s']:.1f} ms, IMU "
        f"{1000 * c['navx']['lag_behind_vicon_s']:.1f} ms; gyro {r['gyro']['yaw_axis']}; "
        f"{r['accelerometer']['mapping']} (fit {r['accelerometer']['fitted_angle_deg']:.1f} deg); truth "
        f"forward axis at {o['forward_axis_in_object_frame_deg']:.2f} deg, axle centre "
        f"{1000 * o['axle_centre_horizontal_distance_m']:.1f} mm beside and "
        f"{-1000 * o['axle_centre_in_object_frame_m'][2]:.0f} mm below the object's origin"
    )
