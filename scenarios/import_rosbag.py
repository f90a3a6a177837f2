"""``slipnav import ros-bag BAG``: a ROS 1 bag (``.bag``) or a ROS 2 bag folder, read with the rosbags
library (no ROS installation), as the project's sensor log, ground truth and model.

The standard topics, each found by its message type:

- ``sensor_msgs/Imu``: ``gyro`` = angular_velocity.z (rad/s); ``acc1_t``, ``acc1_n`` =
  linear_acceleration.x, .y (m/s^2), copied into ``acc2_t``, ``acc2_n`` (one IMU: the checks see no
  accelerometer pair);
- ``sensor_msgs/JointState``: ``enc_R``, ``enc_L``, the positions (rad) of the joints whose names contain
  ``right`` and ``left``, in whole counts of the model's encoder_counts_per_revolution;
- ``nav_msgs/Odometry``: the ground truth (x, y and the yaw of the orientation), from the one topic whose
  name contains ``truth``; wheel odometry on other Odometry topics (``/odom``) is no truth and is left
  out.

There must be exactly one Imu topic and one JointState topic with one right and one left joint. Every
message is stamped by its header (the bag's receive time where the header's stamp is zero), so the
streams share one clock and no lag is estimated. The log covers the interval both sensor streams cover,
on the model's T_N grid, ``interpolate``d or ``hold``; the truth's first pose is the log's initial pose.
The model is ``--model`` (the robot's radii, track and encoder resolution), else the nominal Tinyphoon's
with the report saying so.
"""

from __future__ import annotations

import math
from pathlib import Path as FilePath

import numpy as np
from slipnav.scenarios import alignment as al
from slipnav.scenarios.importers import ImportResult, LogImportError, log_summary, resolve_model
from slipnav.scenarios.model import RobotModel
from slipnav.scenarios.sensor_log import SensorLog

IMU_TYPE = "sensor_msgs/msg/Imu"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
ODOMETRY_TYPE = "nav_msgs/msg/Odometry"
TRUTH_WORD = "truth"


def default_model() -> RobotModel:
    """The nominal Tinyphoon: a bag's robot is described by ``--model``."""
    return RobotModel(
        robot="tinyphoon",
        description="nominal Tinyphoon with the bag's one IMU: give the robot's --model",
        sensor_overrides={"accelerometer_sets": 1},
    ).validate()


def stamp(message, receive_ns: int) -> float:
    """The message's header stamp (s), else (a zero stamp) the bag's receive time."""
    header_stamp = message.header.stamp
    seconds = header_stamp.sec + 1e-9 * header_stamp.nanosec
    return seconds if seconds > 0.0 else 1e-9 * receive_ns


def yaw_of(q) -> float:
    """The rotation about z of a quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))


def pick_topics(connections, bag) -> dict:
    """The IMU, joint-state and truth topics by message type (module docstring); LogImportError naming
    the candidates where there is not exactly one."""
    by_type = {}
    for connection in connections:
        by_type.setdefault(connection.msgtype, set()).add(connection.topic)
    topics = {}
    for role, msgtype in (("imu", IMU_TYPE), ("joints", JOINT_STATE_TYPE)):
        found = sorted(by_type.get(msgtype, ()))
        if len(found) != 1:
            raise LogImportError(
                f"BAG={str(bag)!r} has {len(found)} {msgtype} topics {found}: allowed exactly one"
            )
        topics[role] = found[0]
    truth = sorted(t for t in by_type.get(ODOMETRY_TYPE, ()) if TRUTH_WORD in t.lower())
    if len(truth) > 1:
        raise LogImportError(f"BAG={str(bag)!r} has {len(truth)} truth topics {truth}: allowed at most one")
    topics["truth"] = truth[0] if truth else None
    return topics


def wheel_joints(names, bag) -> tuple[int, int]:
    """The indices of the right and the left wheel's joint among ``names``."""
    found = []
    for side in ("right", "left"):
        matches = [k for k, name in enumerate(names) if side in name.lower()]
        if len(matches) != 1:
            raise LogImportError(
                f"BAG={str(bag)!r}: {len(matches)} joints named *{side}* in {list(names)}: allowed one"
            )
        found.append(matches[0])
    return found[0], found[1]


def read_bag(bag) -> dict:
    """Every stream of the bag's standard topics: ``imu`` (t, gyro, acc (N, 2)), ``wheels`` (t, angles
    (N, 2) right and left), ``truth`` (t, x, y, yaw; empty without a truth topic) and ``topics``."""
    from rosbags.highlevel import AnyReader

    path = FilePath(bag)
    if not path.exists():
        raise LogImportError(
            f"BAG={str(bag)!r} does not exist: allowed a ROS 1 .bag file or a ROS 2 bag folder"
        )
    try:
        with AnyReader([path]) as reader:
            topics = pick_topics(reader.connections, bag)
            streams = {"imu": [], "wheels": [], "truth": []}
            wanted = {topics["imu"]: "imu", topics["joints"]: "wheels", topics["truth"]: "truth"}
            connections = [c for c in reader.connections if c.topic in wanted]
            joints = None
            for connection, receive_ns, raw in reader.messages(connections=connections):
                message = reader.deserialize(raw, connection.msgtype)
                role, t = wanted[connection.topic], stamp(message, receive_ns)
                if role == "imu":
                    w, a = message.angular_velocity, message.linear_acceleration
                    streams["imu"].append((t, w.z, a.x, a.y))
                elif role == "wheels":
                    joints = joints or wheel_joints(message.name, bag)
                    streams["wheels"].append((t, message.position[joints[0]], message.position[joints[1]]))
                else:
                    pose = message.pose.pose
                    streams["truth"].append((t, pose.position.x, pose.position.y, yaw_of(pose.orientation)))
    except LogImportError:
        raise
    except Exception as e:  # rosbags' own errors: a file that is no bag, a broken index
        raise LogImportError(f"BAG={str(bag)!r} cannot be read as a ROS bag: {e}") from None
    out = {
        name: np.array(rows, float).reshape(-1, width)
        for (name, rows), width in zip(streams.items(), (4, 3, 4), strict=True)
    }
    for name in ("imu", "wheels"):
        if len(out[name]) < 2:
            raise LogImportError(f"BAG={str(bag)!r}: {len(out[name])} {name} messages: allowed two or more")
        order = np.argsort(out[name][:, 0], kind="stable")
        out[name] = out[name][order]
    out["truth"] = out["truth"][np.argsort(out["truth"][:, 0], kind="stable")]
    out["topics"] = topics
    return out


def build_log(streams: dict, model: RobotModel, resample: str, name: str) -> tuple[SensorLog, dict, dict]:
    """The sensor log on the model's T_N grid over the interval both sensor streams cover, the truth
    table on the log's clock, and the grid's description."""
    imu, wheels, truth = streams["imu"], streams["wheels"], streams["truth"]
    start, end = max(imu[0, 0], wheels[0, 0]), min(imu[-1, 0], wheels[-1, 0])
    grid = al.uniform_grid(start, end, model.T_N)
    if len(grid) < 2:
        raise LogImportError("BAG: the IMU and the joint states overlap by less than two T_N samples")
    columns = {"t": model.T_N * np.arange(len(grid))}
    columns["gyro"] = al.on_grid(grid, imu[:, 0], imu[:, 1], resample)
    acc = al.on_grid(grid, imu[:, 0], imu[:, 2:4], resample)
    for k in (1, 2):
        columns[f"acc{k}_t"], columns[f"acc{k}_n"] = acc[:, 0].copy(), acc[:, 1].copy()
    counts = model.sensor_parameters().encoder_counts_per_revolution / (2.0 * math.pi)
    angles = al.on_grid(grid, wheels[:, 0], wheels[:, 1:3], resample)
    columns["enc_R"], columns["enc_L"] = np.round(counts * angles[:, 0]), np.round(counts * angles[:, 1])
    table = {"t": truth[:, 0] - start, "x": truth[:, 1], "y": truth[:, 2], "yaw": truth[:, 3]}
    table["quality"] = np.ones(len(truth))
    pose = (0.0, 0.0, 0.0)
    if len(truth) >= 2:
        yaw = np.unwrap(truth[:, 3])
        for key, values in (("true_x", truth[:, 1]), ("true_y", truth[:, 2]), ("true_phi", yaw)):
            columns[key] = np.interp(grid, truth[:, 0], values)
        pose = tuple(float(columns[c][0]) for c in ("true_x", "true_y", "true_phi"))
    metadata = {
        "T_N": model.T_N,
        "T_C": model.T_C,
        "encoder_counts_per_revolution": model.sensor_parameters().encoder_counts_per_revolution,
        "initial_pose": pose,
        "initial_speed": 0.0,
        "scenario": name,
    }
    description = {"T_N_s": model.T_N, "rows": len(grid), "duration_s": float(grid[-1] - grid[0])}
    description["resampling"] = resample
    return SensorLog(columns=columns, metadata=metadata), table, description


def import_trial(bag, model_path=None, resample: str = "interpolate") -> ImportResult:
    """Import one bag (module docstring): the sensor log, the truth table, the model and the report."""
    model, text = resolve_model(model_path, default_model)
    streams = read_bag(bag)
    name = f"ros-bag-{FilePath(bag).resolve().stem}"
    log, table, grid = build_log(streams, model, resample, name)
    topics = streams["topics"]
    report = {
        "adapter": "ros-bag",
        "name": name,
        "files": {"bag": str(bag)},
        "truth_source": f"{topics['truth']} (nav_msgs/Odometry)" if topics["truth"] else "none",
        "topics": topics,
        "messages": {key: int(len(streams[key])) for key in ("imu", "wheels", "truth")},
        "model": "--model" if model_path is not None else "nominal Tinyphoon (no --model)",
        "log": grid,
    }
    return ImportResult(name=name, log=log, truth=table, model=model, model_text=text, report=report)


def summary(r: dict) -> str:
    """One line of what the import found (slipnav import prints it)."""
    t = r["topics"]
    return log_summary(r) + (
        f"IMU {t['imu']} ({r['messages']['imu']} messages), wheels {t['joints']} "
        f"({r['messages']['wheels']}), truth {t['truth'] or 'none'} ({r['messages']['truth']}); model "
        f"{r['model']}"
    )
