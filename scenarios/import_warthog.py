"""``slipnav import norlab-warthog DIR``: the Clearpath Warthog doughnuts of Norlab (Université Laval) with
RTK-GNSS truth, a folder holding the robot's log ``*.csv`` (~20 Hz rows: ``ros_time`` in ns of UTC, 0
before the log starts; ``wheel_pos_left/right`` wheel angles in rad, a 0/0 pair where no new reading came,
new readings at ~5 Hz with gaps up to ~2 s; ``imu_x/y/z`` gyro rates in rad/s) and three RTKLIB
kinematic solutions ``*.pos`` (5 Hz, GPST, latitude, longitude, ellipsoidal height, Q: 1 fix, 2 float,
5 single) of the middle, front and back antennas (told apart by where they sit, below).

What the import estimates (reported in ``<name>.import.json``):

- GPST runs ahead of UTC by the leap seconds of the date (GPS_LEAP_SECONDS); the antennas' positions go to
  a local east-north-up frame at the middle antenna's first fixed position (pymap3d.geodetic2enu);
- which file is which antenna: the middle one lies between the other two (the smallest summed distance
  to them over common fixed epochs); the front one is the one ahead in the direction of travel;
- the truth's heading: the back-to-front baseline's, plus the mounting angle of the baseline against the
  robot's forward axis (the middle antenna's direction of travel over straight, fast stretches, forward
  by the wheels' speed); only epochs where all three antennas are fixed (Q = 1) count as seen;
- the gyro's yaw axis and sign and each stream's residual lag behind the GNSS clock (yaw rates
  cross-correlated, as for the TurtleBot: scenarios/alignment.py).

The truth point is the middle antenna: on a skid-steer robot that slides sideways through its doughnuts the
wheels' kinematics do not locate the axle's centre (the TurtleBot's offset fit needs no lateral
velocity). The log has no accelerometer: its accelerometer columns are empty (``nan``) and the default model
states none (SensorParameters.accelerometer_sets 0: not judged). Wheel angles are interpolated between
readings (``interpolate``, no standstill rule: the gaps are the encoders' dropouts) or held; counts are
2^16 per revolution. A model that states no encoder_hold_time gets importers.HOLD_MARGIN times the
longest interval between the trial's wheel readings, over which the speed may step. The default model
is Kurt3D's (a skid steer taken as differential drive) with the Warthog's wheel radius 0.3 m and
effective track 1.1652 m.
"""

from __future__ import annotations

import datetime as dt
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

WARTHOG_WHEEL_RADIUS = 0.3
WARTHOG_TRACK = 1.1652
COUNTS_PER_REVOLUTION = 65536
GPS_LEAP_SECONDS = ((dt.date(2017, 1, 1), 18), (dt.date(2015, 7, 1), 17), (dt.date(2012, 7, 1), 16))
"""GPS time minus UTC from each date on (IERS bulletins; no leap second since 2017)."""
STRAIGHT_RATE = 0.1
"""rad/s: below this yaw rate, with the antenna faster than STRAIGHT_SPEED, a stretch counts as straight."""
STRAIGHT_SPEED = 0.5


def default_model() -> RobotModel:
    """The Warthog as a model: Kurt3D's sensor set and tuning with the Warthog's radius and track."""
    return RobotModel(
        robot="kurt3d",
        description="Clearpath Warthog (skid steer as differential drive): wheel radius 0.3 m, effective "
        "track 1.1652 m; wheel angles as 65536 counts per revolution; a gyro, no accelerometers",
        robot_overrides={"wheel_radius": WARTHOG_WHEEL_RADIUS, "track_width": WARTHOG_TRACK},
        sensor_overrides={"encoder_counts_per_revolution": COUNTS_PER_REVOLUTION, "accelerometer_sets": 0},
    ).validate()


def gps_minus_utc(day: dt.date) -> int:
    for start, seconds in GPS_LEAP_SECONDS:
        if day >= start:
            return seconds
    raise LogImportError(f"GNSS date {day} is before {GPS_LEAP_SECONDS[-1][0]}: allowed later dates")


def read_pos(path) -> dict:
    """An RTKLIB .pos solution: ``t`` (s of UTC epoch), ``lat``, ``lon``, ``h``, ``q``."""
    rows = []
    try:
        lines = FilePath(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as e:
        raise LogImportError(f"{str(path)!r} cannot be read: {getattr(e, 'strerror', None) or e}") from None
    for number, line in enumerate(lines, 1):
        if not line.strip() or line.startswith("%"):
            continue
        f = line.split()
        try:
            stamp = dt.datetime.strptime(f"{f[0]} {f[1]}", "%Y/%m/%d %H:%M:%S.%f")
            values = [float(v) for v in f[2:6]]
        except (ValueError, IndexError):
            raise LogImportError(f"{str(path)!r}, line {number}: not a GPST solution row") from None
        utc = stamp.replace(tzinfo=dt.timezone.utc).timestamp() - gps_minus_utc(stamp.date())
        rows.append([utc, *values])
    if len(rows) < 10:
        raise LogImportError(f"{str(path)!r} has fewer than 10 solution rows")
    a = np.array(rows)
    return {"t": a[:, 0], "lat": a[:, 1], "lon": a[:, 2], "h": a[:, 3], "q": a[:, 4]}


def find_files(folder) -> tuple[FilePath, list[FilePath]]:
    folder = FilePath(folder)
    if not folder.is_dir():
        raise LogImportError(f"TRIAL_DIR={str(folder)!r} is not a folder: allowed a recording's folder")
    logs, pos = sorted(folder.glob("*.csv")), sorted(folder.glob("*.pos"))
    if len(logs) != 1 or len(pos) != 3:
        raise LogImportError(
            f"TRIAL_DIR={str(folder)!r} holds {len(logs)} .csv and {len(pos)} .pos files: allowed 1 and 3"
        )
    return logs[0], pos


def read_robot_log(path) -> dict:
    names = ["ros_time", "wheel_pos_left", "wheel_pos_right", "imu_x", "imu_y", "imu_z"]
    d = read_table(FilePath(path), names)
    rows = d["ros_time"] > 0
    t = d["ros_time"][rows] * 1e-9
    reading = rows & ~((d["wheel_pos_left"] == 0) & (d["wheel_pos_right"] == 0))
    fresh_gyro = np.r_[True, np.diff(t) > 0]
    t_wheels = d["ros_time"][reading] * 1e-9
    fresh_wheels = np.r_[True, np.diff(t_wheels) > 0]  # a row repeated with its stamp is one reading
    if fresh_gyro.sum() < 10 or fresh_wheels.sum() < 10:
        raise LogImportError(f"{str(path)!r}: fewer than 10 stamped gyro or wheel readings")
    return {
        "t_gyro": t[fresh_gyro],
        "gyro": np.column_stack([d[f"imu_{a}"][rows][fresh_gyro] for a in "xyz"]),
        "t_wheels": t_wheels[fresh_wheels],
        "wheels": np.column_stack([d[f"wheel_pos_{s}"][reading][fresh_wheels] for s in ("right", "left")]),
    }


def _common(a: dict, b: dict, tolerance: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    """Indices (i, j) of the epochs of ``a`` and ``b`` within ``tolerance`` s of each other, both fixed."""
    j = np.clip(np.searchsorted(b["t"], a["t"]), 1, len(b["t"]) - 1)
    j = np.where(np.abs(b["t"][j - 1] - a["t"]) < np.abs(b["t"][j] - a["t"]), j - 1, j)
    ok = (np.abs(b["t"][j] - a["t"]) < tolerance) & (a["q"] == 1) & (b["q"][j] == 1)
    return np.flatnonzero(ok), j[ok]


def antennas(paths, t0: float, t1: float) -> dict:
    """The three antennas in a local ENU frame, named: the middle one between the others, the front one
    ahead (decided later by the travel direction: here ``a`` and ``b`` are the two ends)."""
    import pymap3d

    sols = []
    for p in paths:
        s = read_pos(p)
        keep = (s["t"] >= t0 - 5.0) & (s["t"] <= t1 + 5.0)
        if keep.sum() < 10:
            raise LogImportError(f"{str(p)!r} has fewer than 10 solutions within the robot's log")
        sols.append({k: v[keep] for k, v in s.items()} | {"file": str(p)})
    spread = []
    for k in range(3):
        total = 0.0
        for m in range(3):
            if m != k:
                i, j = _common(sols[k], sols[m])
                total += np.median(np.hypot(*(_ll(sols[k], i) - _ll(sols[m], j)).T)) if len(i) else np.inf
        spread.append(total)
    middle = int(np.argmin(spread))
    ends = [k for k in range(3) if k != middle]
    fixed = sols[middle]["q"] == 1
    if not fixed.any():
        raise LogImportError(f"{sols[middle]['file']!r}: no fixed solution (Q = 1) within the robot's log")
    k0 = int(np.argmax(fixed))
    origin = (sols[middle]["lat"][k0], sols[middle]["lon"][k0], sols[middle]["h"][k0])
    for s in sols:
        e, n, _ = pymap3d.geodetic2enu(s["lat"], s["lon"], s["h"], *origin)
        s["enu"] = np.column_stack([e, n])
    return {"middle": sols[middle], "a": sols[ends[0]], "b": sols[ends[1]], "origin": origin}


def _ll(s: dict, index) -> np.ndarray:
    """Rough local metres of latitude/longitude (for telling the antennas apart only)."""
    lat = np.radians(s["lat"][index])
    return np.column_stack([6.371e6 * lat, 6.371e6 * np.cos(lat) * np.radians(s["lon"][index])])


def _rate(t, angle, step: float = 0.2) -> np.ndarray:
    """Central-difference rate of ``angle`` at epochs whose both neighbours are one ``step`` away (NaN
    elsewhere)."""
    rate = np.full(len(t), np.nan)
    ok = (np.abs(t[2:] - t[1:-1] - step) < 0.05) & (np.abs(t[1:-1] - t[:-2] - step) < 0.05)
    k = np.flatnonzero(ok) + 1
    rate[k] = (angle[k + 1] - angle[k - 1]) / (t[k + 1] - t[k - 1])
    return rate


def wheel_rates(robot_log: dict, model: RobotModel, step: float = 0.05) -> dict:
    """The wheels' mean speed and yaw rate on a uniform grid of the robot's clock (angles interpolated
    between readings, smoothed over 0.5 s)."""
    robot = model.robot_parameters()
    t, angle = robot_log["t_wheels"], robot_log["wheels"]
    grid = al.uniform_grid(t[0], t[-1], step)
    rate = al.smooth(al.on_grid(grid, t, angle, "interpolate"), step, 0.5, 1)
    v_R, v_L = robot.radius_R * rate[:, 0], robot.radius_L * rate[:, 1]
    return {"t": grid, "speed": 0.5 * (v_R + v_L), "yaw_rate": (v_R - v_L) / robot.track_width}


def gnss_truth(ant: dict, wheels: dict) -> dict:
    """The truth at the middle antenna's epochs where all three are fixed: position, heading (the
    baseline's plus its mounting angle), yaw rate; and the mounting angle's fit."""
    mid = ant["middle"]
    ia, ja = _common(mid, ant["a"])
    ib, jb = _common(mid, ant["b"])
    both = np.intersect1d(ia, ib)
    if len(both) < 20:
        raise LogImportError("the three antennas share fewer than 20 fixed epochs within the robot's log")
    a_pos = ant["a"]["enu"][ja[np.searchsorted(ia, both)]]
    b_pos = ant["b"]["enu"][jb[np.searchsorted(ib, both)]]
    t, pos = mid["t"][both], mid["enu"][both]
    baseline = np.unwrap(np.arctan2(*(b_pos - a_pos)[:, ::-1].T))
    rate = _rate(t, baseline)
    velocity = np.column_stack([_rate(t, pos[:, 0]), _rate(t, pos[:, 1])])
    speed = np.interp(t, wheels["t"], wheels["speed"])
    straight = (
        (np.abs(rate) < STRAIGHT_RATE) & (np.hypot(*velocity.T) > STRAIGHT_SPEED) & (np.abs(speed) > 0.2)
    )
    if straight.sum() < 5:
        raise LogImportError("fewer than 5 straight, fast fixed epochs: the truth's heading cannot be fitted")
    travel = np.arctan2(velocity[straight, 1], velocity[straight, 0]) + np.where(
        speed[straight] < 0, np.pi, 0
    )
    mean = np.mean(np.exp(1j * (travel - baseline[straight])))
    mount = float(np.angle(mean))
    return {
        "t": t,
        "position": pos,
        "heading": baseline + mount,
        "yaw_rate": rate,
        "mount": mount,
        "mount_spread": math.degrees(math.sqrt(-2.0 * math.log(abs(mean)))),
        "straight_epochs": int(straight.sum()),
        "front": ant["b"]["file"] if math.cos(mount) > 0 else ant["a"]["file"],
        "back": ant["a"]["file"] if math.cos(mount) > 0 else ant["b"]["file"],
        "middle": mid["file"],
        "baseline_m": float(np.median(np.hypot(*(b_pos - a_pos).T))),
    }


def build_log(robot_log, truth, g, wheel_lag, model, resample, name) -> tuple[SensorLog, dict, dict]:
    """The sensor log on the model's T_N grid over the span the gyro, the wheels and the truth cover, and
    the truth table on the log's clock."""
    imu_lag = g["lag_s"]
    t_g, t_w = robot_log["t_gyro"] - imu_lag, robot_log["t_wheels"] - wheel_lag
    start = max(t_g[0], t_w[0], truth["t"][0])
    end = min(t_g[-1], t_w[-1], truth["t"][-1])
    grid = al.uniform_grid(start, end, model.T_N)
    if len(grid) < 2:
        raise LogImportError("TRIAL_DIR: the robot's log and the truth overlap by less than two T_N samples")
    columns = {"t": model.T_N * np.arange(len(grid))}
    columns["gyro"] = g["sign"] * al.on_grid(grid, t_g, robot_log["gyro"][:, g["axis"]], resample)
    for c in ("acc1_t", "acc1_n", "acc2_t", "acc2_n"):
        columns[c] = np.full(len(grid), np.nan)
    angle = robot_log["wheels"] - robot_log["wheels"][0]
    counts = al.on_grid(grid, t_w, angle, resample) * (
        model.sensor_parameters().encoder_counts_per_revolution / (2 * math.pi)
    )
    columns["enc_R"], columns["enc_L"] = np.round(counts[:, 0]), np.round(counts[:, 1])
    near = (
        np.abs(grid - truth["t"][np.clip(np.searchsorted(truth["t"], grid), 0, len(truth["t"]) - 1)]) <= 0.5
    )
    near |= (
        np.abs(grid - truth["t"][np.clip(np.searchsorted(truth["t"], grid) - 1, 0, len(truth["t"]) - 1)])
        <= 0.5
    )
    pose = [truth["position"][:, 0], truth["position"][:, 1], truth["heading"]]
    for key, values in zip(("true_x", "true_y", "true_phi"), pose, strict=True):
        columns[key] = np.where(near, np.interp(grid, truth["t"], values), np.nan)
    metadata = {
        "T_N": model.T_N,
        "T_C": model.T_C,
        "encoder_counts_per_revolution": model.sensor_parameters().encoder_counts_per_revolution,
        "initial_pose": tuple(float(np.interp(start, truth["t"], v)) for v in pose),
        "scenario": name,
    }
    table = {
        "t": truth["t"] - start,
        "x": truth["position"][:, 0],
        "y": truth["position"][:, 1],
        "yaw": truth["heading"],
        "quality": np.ones(len(truth["t"])),
    }
    described = {"rows": len(grid), "duration_s": float(grid[-1] - grid[0]), "start_utc_s": float(start)}
    return SensorLog(columns=columns, metadata=metadata), table, described


def import_trial(folder, model_path=None, resample: str = "interpolate") -> ImportResult:
    """Import the Warthog recording in ``folder`` (the module docstring)."""
    if resample not in RESAMPLING:
        raise LogImportError(f"--resample={resample!r} is unknown: allowed {', '.join(RESAMPLING)}")
    log_path, pos_paths = find_files(folder)
    model, text = resolve_model(model_path, default_model)
    robot_log = read_robot_log(log_path)
    encoder_hold = float(np.max(np.diff(robot_log["t_wheels"])))
    model, text = with_measured_hold(model, text, "encoder_hold_time", encoder_hold, 10.0)
    wheels = wheel_rates(robot_log, model)
    ant = antennas(pos_paths, robot_log["t_gyro"][0], robot_log["t_gyro"][-1])
    truth = gnss_truth(ant, wheels)
    seen = np.isfinite(truth["yaw_rate"])
    try:
        g = al.select_gyro_axis(
            truth["t"][seen], truth["yaw_rate"][seen], robot_log["t_gyro"], robot_log["gyro"]
        )
        wheel_lag, wheel_corr = al.estimate_lag(
            truth["t"][seen], truth["yaw_rate"][seen], wheels["t"], wheels["yaw_rate"], max_lag=1.0
        )
    except ValueError as e:
        raise LogImportError(f"TRIAL_DIR: {e}") from None
    name = f"norlab-warthog-{FilePath(log_path).stem}"
    log, table, grid = build_log(robot_log, truth, g, wheel_lag, model, resample, name)
    report = {
        "adapter": "norlab-warthog",
        "name": name,
        "files": {
            "log": str(log_path),
            "middle": truth["middle"],
            "front": truth["front"],
            "back": truth["back"],
        },
        "truth_source": f"RTK antennas, the middle one {truth['middle']}; heading from the front and back",
        "clocks": {
            "gnss": {"gps_minus_utc_s": gps_minus_utc(dt.date.fromtimestamp(truth["t"][0]))},
            "gyro": {"lag_behind_gnss_s": g["lag_s"], "yaw_rate_correlation": g["correlation"]},
            "wheels": {"lag_behind_gnss_s": wheel_lag, "yaw_rate_correlation": wheel_corr},
            "log_t0_utc_s": grid["start_utc_s"],
        },
        "gyro": {
            "yaw_axis": ("+" if g["sign"] > 0 else "-") + "xyz"[g["axis"]],
            "axis_correlations": dict(zip("xyz", g["axis_correlations"], strict=True)),
        },
        "truth": {
            "origin_lat_lon_h": ant["origin"],
            "epochs_all_fixed": len(truth["t"]),
            "baseline_m": truth["baseline_m"],
            "baseline_mounting_angle_deg": math.degrees(truth["mount"]),
            "mounting_angle_spread_deg": truth["mount_spread"],
            "straight_epochs": truth["straight_epochs"],
            "point": "the middle antenna",
        },
        "encoders": {
            "readings": len(robot_log["t_wheels"]),
            "counts_per_revolution": COUNTS_PER_REVOLUTION,
            "longest_interval_s": encoder_hold,
            "model_encoder_hold_time_s": model.sensor_parameters().encoder_hold_time,
        },
        "accelerometer": {"mapping": "none: the log's accelerometer columns are empty (nan)"},
        "log": {
            "T_N_s": model.T_N,
            "rows": grid["rows"],
            "duration_s": grid["duration_s"],
            "resampling": resample,
        },
    }
    return ImportResult(name=name, log=log, truth=table, model=model, model_text=text, report=report)


def summary(r: dict) -> str:
    """One line of what the import estimated (slipnav import prints it)."""
    c, t = r["clocks"], r["truth"]
    return log_summary(r) + (
        f"lags behind GNSS (UTC = GPST - {c['gnss']['gps_minus_utc_s']} s): gyro "
        f"{1000 * c['gyro']['lag_behind_gnss_s']:.0f} ms, wheels "
        f"{1000 * c['wheels']['lag_behind_gnss_s']:.0f} ms; "
        f"gyro {r['gyro']['yaw_axis']}; truth at the middle antenna, {t['epochs_all_fixed']} epochs with all "
        f"three fixed, baseline {t['baseline_m']:.3f} m at {t['baseline_mounting_angle_deg']:.1f} deg "
        f"(+- {t['mounting_angle_spread_deg']:.1f}) from the robot's forward axis"
    )
