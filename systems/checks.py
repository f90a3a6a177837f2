"""Checks of physically impossible or unusable settings, shared by the scenario loader and the Python
diagram builders. Each raises ValueError naming the parameter and the allowed range.

The range checks of each parameter set live with it (RobotParameters.__post_init__, ...), written with
systems/ranges.py's require_in; these are the checks across parameters and against what the models can
represent:

- tyre friction mu >= 0.05, and the tyres' traction mu f_w g at least 0.5 m/s^2 beyond the felt shoes'
  Coulomb drag mu_s (1 - f_w) g (Tinyphoon: mu >= 0.126); below it the robot barely moves.
- the speed loop is a PI: kp > 0 and ki > 0 (with either 0 the wheels do not track their command).
- track_width >= 2 wheel_radius: narrower, the two wheels would overlap.
- drive: the motors' current-limited force must accelerate the robot by at least 0.5 m/s^2 beyond the
  felt shoes' Coulomb drag (mass 1e6 kg on Tinyphoon's motors: 4e-6 m/s^2).
- follower gains against T_C (systems/control/path_follower.follower_step): over one control period the
  heading error e = theta - delta moves by theta_dot T_C with theta_dot = ... - k2 e (I(15)), so
  e_K+1 = (1 - k2 T_C) e_K, stable for 0 < k2 T_C < 2; the virtual target s moves by
  (u cos theta + k1 s1) T_C while the robot moves u cos theta T_C, so s1_K+1 = (1 - k1 T_C) s1_K,
  stable for 0 < k1 T_C < 2.
"""

from __future__ import annotations

import math

import numpy as np
from slipnav.systems.robot.parameters import GRAVITY

MIN_TYRE_FRICTION = 0.05
MIN_DRIVE_MARGIN = 0.5  # m/s^2 of drive acceleration beyond the shoes' drag


def require_instance(name: str, value, kind) -> None:
    """``value`` must be a ``kind`` (e.g. a None config passed to a builder)."""
    if not isinstance(value, kind):
        raise ValueError(f"{name} must be a {kind.__name__}, got {value!r}")


def require_seed(seed, name: str = "seed") -> int:
    """An integer noise seed in [0, 2**31 - 1]."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not (0 <= seed < 2**31):
        raise ValueError(f"{name}={seed!r} is out of range: allowed integers 0 .. 2**31-1")
    return int(seed)


def require_finite(name: str, value, low: float = -math.inf, high: float = math.inf) -> float:
    """A finite number in [low, high]."""
    ok = isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    if not ok or not (math.isfinite(value) and low <= value <= high):
        raise ValueError(f"{name}={value!r} is out of range: allowed finite numbers in [{low:g}, {high:g}]")
    return float(value)


def require_pose(name: str, pose) -> tuple:
    """[x, y, phi]: three finite numbers."""
    try:
        values = [float(v) for v in pose]
    except (TypeError, ValueError):
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise ValueError(f"{name}={pose!r} must be three finite numbers [x (m), y (m), phi (rad)]")
    return tuple(values)


def require_table(name: str, table, columns: int, limit: float = math.inf) -> np.ndarray:
    """A finite (n, columns) table, n >= 1, every |entry| <= limit."""
    try:
        a = np.asarray(table, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a table of numbers with {columns} columns") from None
    if a.ndim != 2 or a.shape[1] != columns or a.shape[0] < 1:
        raise ValueError(f"{name} must have shape (n, {columns}), got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} holds NaN or inf at row {int(np.flatnonzero(~np.isfinite(a).all(1))[0])}")
    if np.max(np.abs(a)) > limit:
        raise ValueError(f"{name} reaches |{np.max(np.abs(a)):.4g}|: allowed [-{limit:.4g}, {limit:.4g}]")
    return a


def check_robot_physics(robot, where: str = "") -> None:
    """The cross-parameter checks of the module docstring on a RobotParameters."""
    if robot.tyre_friction < MIN_TYRE_FRICTION:
        raise ValueError(
            f"{where}tyre_friction={robot.tyre_friction!r} is out of range: allowed [{MIN_TYRE_FRICTION}, 2] "
            f"(below {MIN_TYRE_FRICTION} the tyres cannot move the robot against its shoes)"
        )
    for name in ("speed_loop_kp", "speed_loop_ki"):
        value = getattr(robot, name)
        if not value > 0.0:
            raise ValueError(
                f"{where}{name}={value!r} is out of range: allowed (0, inf) (the wheel-speed loop is a PI; "
                "with a zero gain the wheels do not track their command)"
            )
    if robot.track_width < 2.0 * robot.wheel_radius:
        raise ValueError(
            f"{where}track_width={robot.track_width!r} is out of range: allowed [2 wheel_radius = "
            f"{2.0 * robot.wheel_radius:g}, inf) m (narrower, the wheels overlap)"
        )
    drive = 2.0 * robot.motor_constant * robot.motor_current_limit / robot.wheel_radius / robot.mass
    drag = robot.shoe_friction * (1.0 - robot.wheel_load_fraction) * GRAVITY
    traction = robot.tyre_friction * robot.wheel_load_fraction * GRAVITY
    if traction < drag + MIN_DRIVE_MARGIN:
        lowest = (drag + MIN_DRIVE_MARGIN) / (robot.wheel_load_fraction * GRAVITY)
        raise ValueError(
            f"{where}tyre_friction={robot.tyre_friction!r} is out of range: the tyres transmit "
            f"{traction:.3g} m/s^2, less than the shoes' drag {drag:.3g} + {MIN_DRIVE_MARGIN} m/s^2; "
            f"allowed [{max(lowest, MIN_TYRE_FRICTION):.3g}, 2] with this wheel load and shoe friction"
        )
    if drive < drag + MIN_DRIVE_MARGIN:
        largest = 2.0 * robot.motor_constant * robot.motor_current_limit / robot.wheel_radius
        largest /= drag + MIN_DRIVE_MARGIN
        raise ValueError(
            f"{where}mass={robot.mass!r} is out of range: the motors accelerate it at {drive:.3g} m/s^2, "
            f"less than the shoes' drag {drag:.3g} + {MIN_DRIVE_MARGIN} m/s^2; allowed (0, {largest:.4g}] kg "
            "with these motors"
        )


def check_follower_gains(follower, T_C: float, where: str = "follower.") -> None:
    """k1 T_C < 2 and k2 T_C < 2 (the discrete-time follower law; module docstring)."""
    for name in ("k1", "k2"):
        value = getattr(follower, name)
        if not value * T_C < 2.0:
            raise ValueError(
                f"{where}{name}={value!r} is out of range: allowed (0, 2/T_C) = (0, {2.0 / T_C:g}) 1/s "
                f"({name} T_C = {value * T_C:g}; the discrete follower's error is multiplied by "
                f"1 - {name} T_C each control period, unstable beyond 2)"
            )


def check_start_time(start_time, T_C: float, name: str = "start_time") -> None:
    """A controller's start (the standstill before it) is a finite multiple of T_C in [0, 60] s."""
    ok = isinstance(start_time, (int, float)) and math.isfinite(start_time) and 0.0 <= start_time <= 60.0
    if not ok or abs(start_time / T_C - round(start_time / T_C)) > 1e-9:
        raise ValueError(f"{name}={start_time!r} is out of range: allowed [0, 60] s, a multiple of T_C={T_C}")
