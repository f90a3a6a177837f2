"""Reference trajectories (timed, Seyr & Jakubek §V-VI) and paths (geometric, Indiveri §III).

Both are built from the same segments, which a scenario YAML lists with type tags:

    segments:
      - !Straight {length: 1.0, v_end: 2.0}          # constant acceleration to 2 m/s
      - !CosineTurn {angle_deg: 90, length: 0.8}     # kappa(s) = (angle/L)(1 - cos(2 pi s/L))
      - !Arc {radius: 0.5, angle_deg: -45}           # constant curvature, negative = right turn
      - !Straight {length: 1.0, v_peak: 2.5}         # sinusoidal speed bump v0 + (v_peak - v0) sin^2
      - !SpotTurn {angle_deg: 90, duration: 0.8}     # turn on the spot, sinusoidal yaw rate
      - !Pause {duration: 0.5}

A segment's speed is constant unless it gives ``v_end`` (linear in time, i.e. constant acceleration) or
``v_peak`` (sinusoidal "sin^2" bump returning to the entry speed). A trajectory is sampled at T_C with pose,
speed, yaw rate, curvature and arc length; a path keeps a fine arc-length grid with curvature kappa(s).
"""

import dataclasses as dc
import math
from typing import Union

import numpy as np

_FINE_STEP = 1e-4  # s, integration step of the trajectory generator
_PATH_STEP = 1e-3  # m, arc-length grid of paths


class TrajectoryError(ValueError):
    """A trajectory or path definition that cannot be built."""


@dc.dataclass
class Straight:
    """Straight line of ``length`` metres."""

    length: float = 1.0
    v_end: float | None = None
    v_peak: float | None = None


@dc.dataclass
class Arc:
    """Circular arc of ``radius`` metres turning ``angle_deg`` (positive = left)."""

    radius: float = 1.0
    angle_deg: float = 90.0
    v_end: float | None = None
    v_peak: float | None = None


@dc.dataclass
class CosineTurn:
    """Turn of ``angle_deg`` over ``length`` metres with a cosine-shaped curvature profile (Seyr §VI)."""

    angle_deg: float = 90.0
    length: float = 1.0
    v_end: float | None = None
    v_peak: float | None = None


@dc.dataclass
class SpotTurn:
    """Turn on the spot by ``angle_deg`` in ``duration`` seconds with a sinusoidal yaw rate (Seyr §VI)."""

    angle_deg: float = 90.0
    duration: float = 1.0


@dc.dataclass
class Pause:
    """Stand still for ``duration`` seconds."""

    duration: float = 0.5


Segment = Union[Straight, Arc, CosineTurn, SpotTurn, Pause]
PathSegment = Union[Straight, Arc, CosineTurn]


@dc.dataclass
class TrajectoryConfig:
    """A timed trajectory: segments driven in order, starting at ``initial_speed``, ``repeat`` times."""

    segments: list[Segment] = dc.field(default_factory=list)
    initial_speed: float = 0.0
    repeat: int = 1


@dc.dataclass
class PathConfig:
    """A geometric path: segments joined with continuous heading."""

    segments: list[PathSegment] = dc.field(default_factory=list)


# ---------------------------------------------------------------------------------------------------
# Geometry of one segment


def _positive(where: str, name: str, value) -> float:
    if value is None or not math.isfinite(value) or value <= 0.0:
        raise TrajectoryError(f"{where}: {name}={value!r} is out of range: allowed (0, inf)")
    return float(value)


def _geometry(seg, where: str):
    """(length, curvature function of local s) of a rolling segment."""
    if isinstance(seg, Straight):
        length = _positive(where, "length", seg.length)
        return length, lambda s: np.zeros_like(s)
    if isinstance(seg, Arc):
        radius = _positive(where, "radius", seg.radius)
        angle = math.radians(seg.angle_deg)
        if angle == 0.0 or not math.isfinite(angle):
            raise TrajectoryError(f"{where}: angle_deg={seg.angle_deg!r} must be finite and non-zero")
        return radius * abs(angle), lambda s: np.full_like(s, math.copysign(1.0 / radius, angle))
    if isinstance(seg, CosineTurn):
        length = _positive(where, "length", seg.length)
        angle = math.radians(seg.angle_deg)
        if not math.isfinite(angle):
            raise TrajectoryError(f"{where}: angle_deg={seg.angle_deg!r} must be finite")
        return length, lambda s: (angle / length) * (1.0 - np.cos(2.0 * math.pi * s / length))
    raise TrajectoryError(f"{where}: {type(seg).__name__} has no arc length")


def _speed_law(seg, v0: float, length: float, where: str):
    """(duration, v(tau), s(tau), v_end) of a rolling segment entered at speed v0."""
    if seg.v_end is not None and seg.v_peak is not None:
        raise TrajectoryError(f"{where}: give v_end or v_peak, not both")
    if seg.v_peak is not None:
        vp = _positive(where, "v_peak", seg.v_peak)
        T = 2.0 * length / (v0 + vp)
        dv = vp - v0

        def v(tau):
            return v0 + dv * np.sin(math.pi * tau / T) ** 2

        def s(tau):
            return v0 * tau + dv * (tau / 2 - T * np.sin(2 * math.pi * tau / T) / (4 * math.pi))

        return T, v, s, v0
    v1 = v0 if seg.v_end is None else seg.v_end
    if not (math.isfinite(v1) and v1 >= 0.0):
        raise TrajectoryError(f"{where}: v_end={v1!r} is out of range: allowed [0, inf)")
    if v0 + v1 <= 0.0:
        raise TrajectoryError(
            f"{where}: the robot stands still (entry speed 0 and no v_end/v_peak); give v_end > 0 "
            "or v_peak > 0"
        )
    T = 2.0 * length / (v0 + v1)
    acc = (v1 - v0) / T
    return T, (lambda tau: v0 + acc * tau), (lambda tau: v0 * tau + 0.5 * acc * tau * tau), v1


def _integrate(t, v, omega, pose0):
    """Heading and position by trapezoidal integration of S(1) with v_n = 0."""
    dt = np.diff(t)
    phi = pose0[2] + np.concatenate([[0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * dt)])
    vx = v * np.cos(phi)
    vy = v * np.sin(phi)
    x = pose0[0] + np.concatenate([[0.0], np.cumsum(0.5 * (vx[1:] + vx[:-1]) * dt)])
    y = pose0[1] + np.concatenate([[0.0], np.cumsum(0.5 * (vy[1:] + vy[:-1]) * dt)])
    return x, y, phi


# ---------------------------------------------------------------------------------------------------
# Size limits: checked from the segments alone, before any array is allocated.

MAX_TRAJECTORY_SAMPLES = 5_000_000
"""Samples of the trajectory generator's 0.1 ms grid for one repetition (500 s, ~200 MB while building;
the repetitions are built one after the other)."""
MAX_TRAJECTORY_DURATION = 14_400.0
"""The longest trajectory, all repetitions (s): 4 h, 720,000 samples at T_C = 20 ms."""
MAX_PATH_SAMPLES = 2_000_000
"""Samples of a path's 1 mm grid (2 km of path)."""


def trajectory_extent(config: TrajectoryConfig) -> tuple[float, float]:
    """(duration s, length m) of a trajectory, computed from its segments without sampling them."""
    duration, length, v0 = 0.0, 0.0, float(config.initial_speed)
    for i, seg in enumerate(config.segments):
        where = f"trajectory.segments[{i}] ({type(seg).__name__})"
        if isinstance(seg, (SpotTurn, Pause)):
            duration += _positive(where, "duration", seg.duration)
            v0 = 0.0
            continue
        seg_length, _ = _geometry(seg, where)
        T, _, _, v0 = _speed_law(seg, v0, seg_length, where)
        duration += T
        length += seg_length
    repeat = max(int(config.repeat), 1)
    return duration * repeat, length * repeat


def check_trajectory_size(config: TrajectoryConfig) -> None:
    """Reject a trajectory one repetition of which on the 0.1 ms generator grid would exceed
    MAX_TRAJECTORY_SAMPLES, whose repetitions last beyond MAX_TRAJECTORY_DURATION or whose path would
    exceed MAX_PATH_SAMPLES."""
    duration, length = trajectory_extent(config)
    if length / _PATH_STEP > MAX_PATH_SAMPLES:  # the closed loop follows its path on the 1 mm grid
        raise TrajectoryError(
            f"trajectory: the segments are {length:.4g} m long ({length / _PATH_STEP:.3g} samples of the "
            f"{_PATH_STEP * 1e3:g} mm path grid): allowed up to {MAX_PATH_SAMPLES * _PATH_STEP:g} m"
        )
    if duration > MAX_TRAJECTORY_DURATION:
        raise TrajectoryError(
            f"trajectory: the repetitions take {duration:.4g} s: allowed up to {MAX_TRAJECTORY_DURATION:g} s"
        )
    duration /= max(int(config.repeat), 1)  # the generator's grid holds one repetition at a time
    if duration / _FINE_STEP > MAX_TRAJECTORY_SAMPLES:
        raise TrajectoryError(
            f"trajectory: one repetition takes {duration:.4g} s ({duration / _FINE_STEP:.3g} samples of the "
            f"{_FINE_STEP * 1e3:g} ms generator grid): allowed up to "
            f"{MAX_TRAJECTORY_SAMPLES * _FINE_STEP:g} s"
        )


def check_path_size(config: PathConfig) -> None:
    """Reject a path whose 1 mm grid would exceed MAX_PATH_SAMPLES."""
    length = 0.0
    for i, seg in enumerate(config.segments):
        if isinstance(seg, (Straight, Arc, CosineTurn)):
            length += _geometry(seg, f"path.segments[{i}] ({type(seg).__name__})")[0]
    if length / _PATH_STEP > MAX_PATH_SAMPLES:
        raise TrajectoryError(
            f"path: the segments are {length:.4g} m long ({length / _PATH_STEP:.3g} samples of the "
            f"{_PATH_STEP * 1e3:g} mm grid): allowed up to {MAX_PATH_SAMPLES * _PATH_STEP:g} m"
        )


# ---------------------------------------------------------------------------------------------------
# Trajectories


@dc.dataclass(frozen=True)
class Trajectory:
    """A pre-planned trajectory sampled at T_C (Seyr's ^T x_ref(K), K = 0, 1, ...).

    All arrays have one entry per control sample K; the last sample is the end pose at rest (or at the
    final speed). ``kappa`` is the geometric curvature (+/-inf during a turn on the spot).
    """

    T_C: float
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    phi: np.ndarray
    v: np.ndarray
    omega: np.ndarray
    kappa: np.ndarray
    s: np.ndarray

    @property
    def duration(self) -> float:
        return float(self.t[-1])

    @property
    def length(self) -> float:
        """Arc length driven (m)."""
        return float(self.s[-1])

    @property
    def num_samples(self) -> int:
        return len(self.t)

    def wheel_speeds(self, track_width: float) -> tuple[np.ndarray, np.ndarray]:
        """Rolling-without-slip wheel speeds v_R = v + omega*b/2, v_L = v - omega*b/2 (S(10) inverted)."""
        half = 0.5 * track_width
        return self.v + half * self.omega, self.v - half * self.omega


def build_trajectory(config: TrajectoryConfig, T_C: float, pose0=(0.0, 0.0, 0.0)) -> Trajectory:
    """Integrate the segments of ``config`` and sample the result every T_C."""
    if not config.segments:
        raise TrajectoryError("trajectory.segments is empty: give at least one segment")
    if not (isinstance(config.repeat, int) and 1 <= config.repeat <= 1000):
        raise TrajectoryError(f"trajectory.repeat={config.repeat!r} is out of range: allowed 1..1000")
    if not (math.isfinite(config.initial_speed) and config.initial_speed >= 0.0):
        raise TrajectoryError(
            f"trajectory.initial_speed={config.initial_speed!r} is out of range: allowed [0, inf)"
        )
    t0, s0, v0 = 0.0, 0.0, float(config.initial_speed)
    pose, samples = tuple(pose0), []
    for rep in range(config.repeat):
        (t, v, w, kappa, s), v0 = _repetition(config, rep, t0, s0, v0)
        x, y, phi = _integrate(t, v, w, pose)
        last = rep == config.repeat - 1
        samples.append(_sampled(t, v, w, kappa, s, x, y, phi, T_C, last))
        t0, s0, pose = t[-1], s[-1], (x[-1], y[-1], phi[-1])
    tc, x, y, phi, v, w, kappa, s = (np.concatenate(column) for column in zip(*samples, strict=True))
    return Trajectory(T_C=T_C, t=tc, x=x, y=y, phi=phi, v=v, omega=w, kappa=kappa, s=s)


def _repetition(config: TrajectoryConfig, rep: int, t0: float, s0: float, v0: float) -> tuple:
    """The 0.1 ms grid of repetition ``rep`` from time t0 (s), arc length s0 (m) and entry speed v0
    (m/s): ((t, v, omega, kappa, s), the exit speed)."""
    pieces_t, pieces_v, pieces_w, pieces_k, pieces_s = [], [], [], [], []
    for i, seg in enumerate(config.segments):
        where = f"trajectory.segments[{i}] ({type(seg).__name__})" + (
            f", repetition {rep + 1}" if config.repeat > 1 else ""
        )
        if isinstance(seg, (SpotTurn, Pause)):
            T = _positive(where, "duration", seg.duration)
            if v0 != 0.0:
                raise TrajectoryError(f"{where}: needs the robot at rest; entry speed is {v0} m/s")
            tau = np.linspace(0.0, T, max(int(math.ceil(T / _FINE_STEP)), 2) + 1)
            angle = math.radians(seg.angle_deg) if isinstance(seg, SpotTurn) else 0.0
            w = (angle / T) * (1.0 - np.cos(2.0 * math.pi * tau / T))
            v = np.zeros_like(tau)
            kappa = np.full_like(tau, math.copysign(math.inf, angle) if angle else 0.0)
            s = np.full_like(tau, s0)
            v1 = 0.0
        else:
            length, curvature = _geometry(seg, where)
            T, v_of, s_of, v1 = _speed_law(seg, v0, length, where)
            tau = np.linspace(0.0, T, max(int(math.ceil(T / _FINE_STEP)), 2) + 1)
            v = v_of(tau)
            s_local = np.clip(s_of(tau), 0.0, length)
            kappa = curvature(s_local)
            w = v * kappa
            s = s0 + s_local
            s0 += length
        pieces_t.append(t0 + tau)
        pieces_v.append(v)
        pieces_w.append(w)
        pieces_k.append(kappa)
        pieces_s.append(s)
        t0 += tau[-1]
        v0 = v1
    columns = (pieces_t, pieces_v, pieces_w, pieces_k, pieces_s)
    return tuple(np.concatenate(column) for column in columns), v0


def _sampled(t, v, w, kappa, s, x, y, phi, T_C: float, last: bool) -> tuple:
    """One repetition's fine grid sampled at the k T_C in [t[0], t[-1]) (the last repetition: up to
    the first k T_C at or after t[-1], where v holds its final value): (t, x, y, phi, v, omega, kappa,
    s). At a segment joint the later piece wins (np.interp on a non-decreasing grid)."""
    first = int(math.ceil(t[0] / T_C - 1e-9))
    n = int(math.floor(t[-1] / T_C + 1e-9)) + 1
    tc = np.arange(first, n) * T_C
    if last and tc[-1] < t[-1] - 1e-12:
        tc = np.append(tc, n * T_C)
    elif not last and tc[-1] >= t[-1] - 1e-9:
        tc = tc[:-1]  # the joint's sample is the next repetition's
    idx = np.clip(np.searchsorted(t, tc, side="right") - 1, 0, len(t) - 1)

    def at(a):
        return np.interp(tc, t, a)

    return tc, at(x), at(y), at(phi), np.where(tc > t[-1], v[-1], at(v)), at(w), kappa[idx], at(s)


# ---------------------------------------------------------------------------------------------------
# Paths


@dc.dataclass(frozen=True)
class Path:
    """A planar path with curvature kappa(s) on an arc-length grid (Indiveri's reference path l(s))."""

    s: np.ndarray
    x: np.ndarray
    y: np.ndarray
    phi: np.ndarray
    kappa: np.ndarray

    @property
    def length(self) -> float:
        return float(self.s[-1])

    @property
    def max_abs_curvature(self) -> float:
        return float(np.max(np.abs(self.kappa)))

    def curvature(self, s: float) -> float:
        """kappa_r(s), clamped to the ends."""
        return float(np.interp(s, self.s, self.kappa))

    def pose(self, s: float) -> np.ndarray:
        """[x, y, phi] of the path point at arc length s (heading unwrapped), clamped to the ends."""
        return np.array([np.interp(s, self.s, a) for a in (self.x, self.y, self.phi)])


def build_path(config: PathConfig, pose0=(0.0, 0.0, 0.0)) -> Path:
    """Sample the segments of ``config`` every millimetre of arc length."""
    if not config.segments:
        raise TrajectoryError("path.segments is empty: give at least one segment")
    s_parts, k_parts = [], []
    s0 = 0.0
    for i, seg in enumerate(config.segments):
        where = f"path.segments[{i}] ({type(seg).__name__})"
        if not isinstance(seg, (Straight, Arc, CosineTurn)):
            raise TrajectoryError(f"{where}: a path takes Straight, Arc and CosineTurn segments only")
        if seg.v_end is not None or seg.v_peak is not None:
            raise TrajectoryError(f"{where}: a path is geometric; v_end/v_peak belong to trajectories")
        length, curvature = _geometry(seg, where)
        local = np.linspace(0.0, length, max(int(math.ceil(length / _PATH_STEP)), 2) + 1)
        s_parts.append(s0 + local)
        k_parts.append(curvature(local))
        s0 += length
    s = np.concatenate(s_parts)
    kappa = np.concatenate(k_parts)
    # Unit speed along s: the same integrator with t := s, v := 1, omega := kappa.
    x, y, phi = _integrate(s, np.ones_like(s), kappa, pose0)
    keep = np.concatenate([[True], np.diff(s) > 0.0])  # drop duplicated joints for interpolation
    return Path(s=s[keep], x=x[keep], y=y[keep], phi=phi[keep], kappa=kappa[keep])


def trajectory_along_path(path: Path, speed: float, T_C: float) -> Trajectory:
    """Drive ``path`` at a constant ``speed`` (the open-loop reference of a path scenario)."""
    speed = _positive("path speed", "speed", speed)
    tc = np.arange(int(math.floor(path.length / speed / T_C)) + 2) * T_C
    s = np.minimum(tc * speed, path.length)
    moving = tc * speed < path.length
    kappa = np.interp(s, path.s, path.kappa)
    return Trajectory(
        T_C=T_C,
        t=tc,
        x=np.interp(s, path.s, path.x),
        y=np.interp(s, path.s, path.y),
        phi=np.interp(s, path.s, path.phi),
        v=np.where(moving, speed, 0.0),
        omega=np.where(moving, speed * kappa, 0.0),
        kappa=kappa,
        s=s,
    )


def trajectory_path(config: TrajectoryConfig, pose0=(0.0, 0.0, 0.0)) -> Path:
    """The geometric path of a trajectory (its rolling segments, repeated), for the path follower; a
    Pause adds no path (the trajectory's arc length stands still during it)."""
    segments = []
    for _ in range(config.repeat):
        for i, seg in enumerate(config.segments):
            if isinstance(seg, Pause):
                continue
            if isinstance(seg, SpotTurn):
                raise TrajectoryError(
                    f"trajectory.segments[{i}] (SpotTurn): the closed loop follows the trajectory's path "
                    "with a path follower, which needs rolling segments (CosineTurn, Arc) or a Pause"
                )
            segments.append(dc.replace(seg, v_end=None, v_peak=None))
    return build_path(PathConfig(segments=segments), pose0)
