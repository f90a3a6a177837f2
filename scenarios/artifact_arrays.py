"""The run artifact's arrays (docs/artifacts.md) from a diagram's loggers: their keys and
``collect_arrays``.

Every array is logged on the T_N grid by Drake loggers, which publish at t_k before the discrete updates
of t_k: a row holds the true continuous state at t_k and the discrete signals (sensor samples ``meas_*``,
commands) as the blocks updating at t_k read them.
"""

from __future__ import annotations

import numpy as np
from slipnav.systems.health.perturbation import FORCE_CHANNELS, PERTURBATION_CHANNELS
from slipnav.systems.robot.contact import tyre_slip
from slipnav.systems.robot.faults import SENSOR_CHANNELS
from slipnav.systems.robot.parameters import RobotParameters

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


def collect_arrays(loggers, context, robot: RobotParameters, copy: bool = True) -> dict:
    """Artifact arrays from the loggers of a diagram (every logger publishes on the T_N grid). The wheel
    speeds, angles and tyre slips are computed from the logged plant state (systems.robot.contact.tyre_slip).
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


YAW_CALIBRATION_KEYS = (None, "est_radius_difference", "est_gyro_bias_std", "est_radius_difference_std")
YAW_CALIBRATION_KEYS += (None, None, "gyro_bias_changes")
"""The keys of the yaw calibration's parameters [b_g, D, sigma(b_g), sigma(D), learned, rejected, bias
changes] (calibration_parameters; b_g is ``est_gyro_bias``, the ``gyro_bias`` output)."""
NAVIGATION_SIGNALS = (
    ("nav_pose", ("est_x", "est_y", "est_phi")),
    ("nav_odometry_pose", ("odo_x", "odo_y", "odo_phi")),
    ("nav_gyrodometry_pose", ("gyro_x", "gyro_y", "gyro_phi")),
    ("nav_mixed_estimate", ("est_v_t", "est_v_n", "est_omega", "est_a_t", "est_a_n")),
    ("nav_side_slip_angle", ("est_alpha",)),
    ("nav_track_speed", ("est_track_speed",)),
    ("nav_C1", ("C1",)),
    ("nav_slide_onset", ("slide_onset",)),
    ("nav_C2_C3", ("C2", "C3")),
    ("nav_tyre_model_check", ("tyre_model_weight", "free_v_n", None, "est_tyre_peak")),
    ("nav_delta_v", ("delta_v",)),
    ("nav_odometry", ("odo_v_t", "odo_omega")),
    ("nav_gyro_bias", ("est_gyro_bias",)),
    ("nav_standstill", ("standstill",)),
    ("nav_accelerometer_bias", tuple(f"est_accel_bias_{axis}" for axis in ("t1", "n1", "t2", "n2"))),
    ("nav_health", tuple(f"health_{channel}" for channel in SENSOR_CHANNELS)),
    ("nav_yaw_calibration", YAW_CALIBRATION_KEYS),
)
"""The artifact's navigation keys, in its order: per logged navigation output (``nav_<output>``,
diagrams/navigation.py) the key of each of its leading elements (None: no key). ``fault`` follows from
``nav_health`` and ``nav_encoder_fault`` (collect_navigation)."""


def collect_navigation(a: dict, data) -> None:
    """The navigation keys of the artifact (NAVIGATION_SIGNALS, then ``fault``) from the navigation
    diagram's loggers (``data(name)``: the logger's rows x samples; the keys are views of its rows)."""
    for name, keys in NAVIGATION_SIGNALS:
        rows = data(name)
        for i, key in enumerate(keys):
            if key is not None:
                a[key] = rows[i]
    health = data("nav_health")
    # a channel excluded (any health code > 0; an absent accelerometer set is none), or the odometry held
    excluded = (np.max(health[0:5], axis=0) > 0).astype(float)
    a["fault"] = np.maximum(excluded, data("nav_encoder_fault")[0])
