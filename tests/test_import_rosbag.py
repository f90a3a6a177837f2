"""ROS bags (scenarios/import_rosbag.py): a ROS 2 bag the test writes itself with the rosbags library,
holding the standard topics of a robot driving a known motion, imports as a sensor log that replays."""

import math

import numpy as np
import pytest
from slipnav.scenarios.import_rosbag import import_trial
from slipnav.scenarios.importers import LogImportError
from slipnav.scenarios.model import RobotModel, model_text
from slipnav.scenarios.replay import replay_log
from slipnav.studies.cli import main

R, TRACK = 0.03, 0.2
IMU_RATE, JOINT_RATE, TRUTH_RATE = 100.0, 50.0, 20.0


def motion(t):
    """v = 0.3 m/s and omega = 0.5 sin(0.4 t) rad/s: (v, omega, x, y, heading) at ``t`` (closed form of
    the heading; the position integrated finely)."""
    fine = np.arange(0.0, float(np.max(t)) + 1e-3, 1e-3)
    heading = 1.25 * (1.0 - np.cos(0.4 * fine))
    x = np.concatenate([[0.0], np.cumsum(0.3 * np.cos(heading[:-1]) * 1e-3)])
    y = np.concatenate([[0.0], np.cumsum(0.3 * np.sin(heading[:-1]) * 1e-3)])
    return (
        np.full_like(t, 0.3),
        0.5 * np.sin(0.4 * t),
        np.interp(t, fine, x),
        np.interp(t, fine, y),
        1.25 * (1.0 - np.cos(0.4 * t)),
    )


def write_bag(path, duration=10.0, with_truth=True, second_imu=False):
    from rosbags.rosbag2 import Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    types = store.types
    Time, Header = types["builtin_interfaces/msg/Time"], types["std_msgs/msg/Header"]
    Vector3, Quaternion = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]
    Point, Pose = types["geometry_msgs/msg/Point"], types["geometry_msgs/msg/Pose"]
    PoseCov, Twist = types["geometry_msgs/msg/PoseWithCovariance"], types["geometry_msgs/msg/Twist"]
    TwistCov = types["geometry_msgs/msg/TwistWithCovariance"]
    Imu, JointState = types["sensor_msgs/msg/Imu"], types["sensor_msgs/msg/JointState"]
    Odometry = types["nav_msgs/msg/Odometry"]
    start = 1_700_000_000.0

    def header(t):
        seconds = start + t
        return Header(stamp=Time(sec=int(seconds), nanosec=int(round((seconds % 1) * 1e9))), frame_id="base")

    def odometry(t, x, y, yaw):
        pose = Pose(
            position=Point(x=x, y=y, z=0.0),
            orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
        )
        twist = Twist(linear=Vector3(x=0.0, y=0.0, z=0.0), angular=Vector3(x=0.0, y=0.0, z=0.0))
        return Odometry(
            header=header(t),
            child_frame_id="base",
            pose=PoseCov(pose=pose, covariance=np.zeros(36)),
            twist=TwistCov(twist=twist, covariance=np.zeros(36)),
        )

    messages = []
    t_imu = np.arange(0.0, duration, 1.0 / IMU_RATE)
    v, omega, *_ = motion(t_imu)
    for k, t in enumerate(t_imu):
        zero = np.zeros(9)
        imu = Imu(
            header=header(t),
            orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=zero,
            angular_velocity=Vector3(x=0.0, y=0.0, z=float(omega[k])),
            angular_velocity_covariance=zero,
            linear_acceleration=Vector3(x=0.0, y=float(v[k] * omega[k]), z=9.81),
            linear_acceleration_covariance=zero,
        )
        messages.append(("/imu", Imu.__msgtype__, t, imu))
        if second_imu:
            messages.append(("/imu2", Imu.__msgtype__, t, imu))
    t_joint = np.arange(0.0, duration, 1.0 / JOINT_RATE)
    _, _, _, _, heading = motion(t_joint)
    travelled = 0.3 * t_joint
    for k, t in enumerate(t_joint):
        right = (travelled[k] + 0.5 * TRACK * heading[k]) / R
        left = (travelled[k] - 0.5 * TRACK * heading[k]) / R
        joints = JointState(
            header=header(t),
            name=["left_wheel_joint", "right_wheel_joint"],
            position=np.array([left, right]),
            velocity=np.zeros(2),
            effort=np.zeros(2),
        )
        messages.append(("/joint_states", JointState.__msgtype__, t, joints))
    t_truth = np.arange(0.0, duration, 1.0 / TRUTH_RATE)
    _, _, x, y, heading = motion(t_truth)
    for k, t in enumerate(t_truth):
        if with_truth:
            messages.append(("/ground_truth", Odometry.__msgtype__, t, odometry(t, x[k], y[k], heading[k])))
        messages.append(("/odom", Odometry.__msgtype__, t, odometry(t, 0.0, 0.0, 0.0)))  # wheel odometry
    with Writer(path, version=8) as writer:
        connections = {}
        for topic, msgtype, t, message in sorted(messages, key=lambda m: m[2]):
            if topic not in connections:
                connections[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(connections[topic], int((start + t) * 1e9), store.serialize_cdr(message, msgtype))


def robot_model():
    return RobotModel(
        robot="tinyphoon",
        robot_overrides={"wheel_radius": R, "track_width": TRACK},
        sensor_overrides={"encoder_counts_per_revolution": 4096},
    ).validate()


@pytest.fixture(scope="module")
def bag(tmp_path_factory):
    folder = tmp_path_factory.mktemp("bags")
    (folder / "robot.model.yaml").write_text(model_text(robot_model()))
    write_bag(folder / "drive")
    return folder


def test_a_bag_imports_its_standard_topics_on_the_grid(bag):
    result = import_trial(bag / "drive", bag / "robot.model.yaml")
    c, r = result.log.columns, result.report
    assert r["topics"] == {"imu": "/imu", "joints": "/joint_states", "truth": "/ground_truth"}
    assert r["messages"] == {"imu": 1000, "wheels": 500, "truth": 200}
    t = c["t"]
    assert t[1] - t[0] == pytest.approx(0.002) and 9.9 - 0.003 < t[-1] <= 9.99
    _, omega, *_ = motion(t)  # the grid starts at the streams' common first stamp, t = 0
    np.testing.assert_allclose(c["gyro"], omega, atol=3e-4)  # linear between 100 Hz samples
    assert np.array_equal(c["acc1_n"], c["acc2_n"]) and np.array_equal(c["acc1_t"], c["acc2_t"])
    counts = 4096 / (2 * math.pi)
    np.testing.assert_allclose(
        c["enc_R"] - c["enc_L"], np.round(counts * TRACK * (1.25 * (1 - np.cos(0.4 * t))) / R), atol=2.0
    )
    assert result.truth["t"][0] == 0.0 and len(result.truth["t"]) == 200
    assert result.log.metadata["initial_pose"] == (0.0, 0.0, 0.0)


def test_the_imported_bag_replays_along_its_truth(bag):
    result = import_trial(bag / "drive", bag / "robot.model.yaml")
    replay = replay_log(result.log, result.model, result.name)
    x, y = replay.arrays["gyro_x"][-1], replay.arrays["gyro_y"][-1]  # Gyrodometry
    _, _, x_true, y_true, _ = motion(np.array([replay.arrays["t"][-1]]))
    assert math.hypot(x - x_true[0], y - y_true[0]) < 0.02  # 3 m driven
    assert np.isfinite(replay.arrays["est_x"]).all()


def test_the_import_command_writes_the_log_truth_model_and_report(bag, tmp_path, capsys):
    argv = [
        "import",
        "ros-bag",
        str(bag / "drive"),
        "--model",
        str(bag / "robot.model.yaml"),
        "--out",
        str(tmp_path),
    ]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "IMU /imu (1000 messages), wheels /joint_states (500), truth /ground_truth (200)" in out
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == [f"ros-bag-drive.{s}" for s in ("import.json", "model.yaml", "sensors.csv", "truth.csv")]


def test_a_bag_with_two_imus_or_no_bag_is_a_clear_error(tmp_path):
    write_bag(tmp_path / "two", duration=1.0, second_imu=True)
    with pytest.raises(
        LogImportError, match=r"2 sensor_msgs/msg/Imu topics \['/imu', '/imu2'\]: allowed exactly one"
    ):
        import_trial(tmp_path / "two")
    with pytest.raises(LogImportError, match="does not exist"):
        import_trial(tmp_path / "missing")
    (tmp_path / "junk.bag").write_text("not a bag")
    with pytest.raises(LogImportError, match="cannot be read as a ROS bag"):
        import_trial(tmp_path / "junk.bag")
