"""A calibration session on disk: a real robot's own sensor logs and the hand measurements of a lab.

``slipnav calibrate SESSION.yaml`` identifies a robot from the session file (README.md: Calibration
sessions) and the sensor logs it names (README.md: Sensor log), exactly as ``--simulate`` does from the
simulated runs (studies/calibration.py calibrate). ``slipnav calibrate --simulate ROBOT --seed N --logs``
writes its simulated session in this format and calibrates from reading it back, so the path a real
robot's logs take is the one the tests exercise.

The session file::

    robot: tinyphoon                  # the nominal robot (data sheet)
    description: lab, 2026-11-23      # free text
    manoeuvres:
      - {kind: standstill, log: 00-standstill.sensors.csv}
      - {kind: spot_turn, log: 01-spot_turn.sensors.csv, measured_pose: [0.0, 0.0, 18.85],
         pose_std: [0.001, 0.0044], speed: 0.3, turns: 3}
      ...

``log`` is read from the session file's folder; ``measured_pose`` is the final pose measured by hand
relative to the start (m, m, rad; the heading unwrapped: the whole revolutions counted), ``pose_std``
the measurement's (position, heading) standard deviations, ``speed`` the cruise speed commanded (m/s),
``turns`` the spot turn's revolutions, ``motors_off`` a coasting run's [start, end] (s from the log's
first row) while the motors were switched off (from the lab's own command record).
"""

import dataclasses as dc
import math
import os
import shutil
import tempfile
from pathlib import Path as FilePath

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from slipnav.scenarios.files import permissions_as_umask
from slipnav.scenarios.sensor_log import (
    SensorLogError,
    read_sensor_log,
    write_sensor_log,
)
from slipnav.scenarios.typed_yaml import ScenarioError, check_schema, load_yaml
from slipnav.studies.calibration_identify import _turn_data
from slipnav.studies.calibration_manoeuvres import HEADING_STD, POSITION_STD, Manoeuvre, manoeuvre_plan
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import ROBOTS, robot_parameters

MEASURED_KINDS = ("spot_turn", "straight", "square")
"""Manoeuvres whose final pose must be measured by hand."""
SESSION_FILE = "session.yaml"


@dc.dataclass
class SessionManoeuvre:
    """One manoeuvre of a session file (module docstring)."""

    kind: str = ""
    log: str = ""
    measured_pose: list[float] | None = None
    pose_std: list[float] = dc.field(default_factory=lambda: [POSITION_STD, HEADING_STD])
    speed: float = 0.0
    turns: float = 0.0
    motors_off: list[float] | None = None


@dc.dataclass
class CalibrationSession:
    """A session file (module docstring).

    Args:
        robot: the nominal robot, ``tinyphoon`` or ``kurt3d``.
        description: free text.
        T_N, T_C: the logs' sample period and the control period (s).
        manoeuvres: the manoeuvres, any order.
    """

    robot: str = "tinyphoon"
    description: str = ""
    T_N: float = 0.002
    T_C: float = 0.02
    manoeuvres: list[SessionManoeuvre] = dc.field(default_factory=list)


def _check_session(session: CalibrationSession, where: str) -> None:
    if session.robot not in ROBOTS:
        raise ScenarioError(f"{where}: robot={session.robot!r} is unknown: allowed {sorted(ROBOTS)}")
    try:
        rates = SampleRates(T_N=session.T_N, T_C=session.T_C)
    except ValueError as e:
        raise ScenarioError(f"{where}: {e}") from None
    kinds = sorted({kind for kind, *_ in manoeuvre_plan(robot_parameters(session.robot), rates.T_C)})
    if not session.manoeuvres:
        raise ScenarioError(f"{where}: manoeuvres is empty: allowed a list of {kinds}")
    for i, m in enumerate(session.manoeuvres):
        at = f"{where}: manoeuvres[{i}]"
        if m.kind not in kinds:
            raise ScenarioError(f"{at}.kind={m.kind!r} is unknown: allowed {kinds}")
        if not m.log:
            raise ScenarioError(f"{at}.log is missing: allowed a sensor log CSV path")
        if m.kind in MEASURED_KINDS and m.measured_pose is None:
            raise ScenarioError(f"{at}.measured_pose is missing: a {m.kind} needs its final pose [x, y, phi]")
        if m.measured_pose is not None and (
            len(m.measured_pose) != 3 or not all(math.isfinite(v) for v in m.measured_pose)
        ):
            raise ScenarioError(f"{at}.measured_pose={m.measured_pose!r}: allowed three finite numbers")
        if len(m.pose_std) != 2 or not all(math.isfinite(v) and v > 0.0 for v in m.pose_std):
            raise ScenarioError(f"{at}.pose_std={m.pose_std!r}: allowed two numbers > 0 (m, rad)")
        for key in ("speed", "turns"):
            value = getattr(m, key)
            if not (math.isfinite(value) and value >= 0.0):
                raise ScenarioError(f"{at}.{key}={value!r} is out of range: allowed [0, inf)")
        if m.kind == "coast" and m.motors_off is None:
            raise ScenarioError(
                f"{at}.motors_off is missing: a coast needs [start, end] of the motors off (s)"
            )
        if m.motors_off is not None and (
            len(m.motors_off) != 2
            or not all(math.isfinite(v) for v in m.motors_off)
            or not 0.0 <= m.motors_off[0] < m.motors_off[1]
        ):
            raise ScenarioError(
                f"{at}.motors_off={m.motors_off!r}: allowed [start, end] with 0 <= start < end (s)"
            )


def read_session(path) -> tuple[CalibrationSession, list[Manoeuvre]]:
    """Read a session file and every log it names; ScenarioError naming the key, or the log's column and
    row (read_sensor_log), before anything is identified."""
    path = FilePath(path)
    where = f"calibration session {str(path)!r}"
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(f"{where} cannot be read: {getattr(e, 'strerror', None) or e}") from None
    raw = load_yaml(text)
    if not isinstance(raw, dict):
        raise ScenarioError(f"{where}: expected a mapping of keys (README.md: Calibration sessions)")
    try:
        check_schema(CalibrationSession, raw, "")
    except ScenarioError as e:
        raise ScenarioError(f"{where}: {e}") from None
    session = yaml_load_typed(schema=CalibrationSession, data=text)
    _check_session(session, where)
    manoeuvres = []
    for i, m in enumerate(session.manoeuvres):
        log_path = path.parent / m.log
        if not log_path.is_file():
            raise ScenarioError(f"{where}: manoeuvres[{i}].log={m.log!r}: no such file {str(log_path)!r}")
        try:
            log = read_sensor_log(log_path, session.T_N)
        except SensorLogError as e:
            raise ScenarioError(f"{where}: manoeuvres[{i}].log: {e}") from None
        pose = None if m.measured_pose is None else tuple(float(v) for v in m.measured_pose)
        off = None if m.motors_off is None else tuple(float(v) for v in m.motors_off)
        manoeuvres.append(
            Manoeuvre(m.kind, log, pose, tuple(m.pose_std), speed=m.speed, turns=m.turns, motors_off=off)
        )
        check_heading_unwrapped(manoeuvres[-1], session.T_N, f"{where}: manoeuvres[{i}]")
    return session, manoeuvres


def check_heading_unwrapped(manoeuvre: Manoeuvre, T_N: float, where: str) -> None:
    """A hand-measured final heading counts the whole revolutions: it lies within half a turn of what the
    de-biased gyro turned (a gyro's scale error is a few per cent, a twentieth of a turn on 3 revolutions).
    A heading measured modulo 2 pi would make the identified radii and track width wrong by tens of per
    cent; ScenarioError naming ``measured_pose[2]`` and the unwrapped value the gyro suggests."""
    if manoeuvre.measured_pose is None:
        return
    turned, _, _ = _turn_data(manoeuvre, T_N)
    measured = manoeuvre.measured_pose[2]
    if not math.isfinite(turned) or abs(turned - measured) <= math.pi:
        return
    unwrapped = measured + 2.0 * math.pi * round((turned - measured) / (2.0 * math.pi))
    raise ScenarioError(
        f"{where}.measured_pose[2]={measured!r} rad is half a turn or more from the {turned:.4g} rad the "
        "gyro turned: allowed a heading within half a turn of the gyro's, the whole revolutions counted "
        f"(measured modulo 2 pi, this one is {unwrapped:.6g} rad; else the log is another manoeuvre's; "
        "README.md: Calibration sessions)"
    )


def write_session(manoeuvres: list[Manoeuvre], folder, robot: str, description: str = "", rates=None):
    """Write ``manoeuvres`` as a session folder (``NN-kind.sensors.csv`` and ``session.yaml``), atomically:
    staged in a hidden sibling folder and renamed, so that an interrupted write leaves nothing half.
    Returns the session file's path."""
    rates = rates or SampleRates()
    folder = FilePath(folder)
    if folder.exists():
        raise ScenarioError(f"calibration session folder {str(folder)!r} exists: allowed a new folder")
    staging = FilePath(tempfile.mkdtemp(dir=folder.parent, prefix=f".{folder.name}.partial-"))
    try:
        permissions_as_umask(staging, directory=True)
        entries = []
        for i, m in enumerate(manoeuvres):
            name = f"{i:02d}-{m.kind}.sensors.csv"
            write_sensor_log(m.log, staging / name)
            entries.append(
                SessionManoeuvre(
                    kind=m.kind,
                    log=name,
                    measured_pose=None if m.measured_pose is None else [float(v) for v in m.measured_pose],
                    pose_std=[float(v) for v in m.pose_std],
                    speed=float(m.speed),
                    turns=float(m.turns),
                    motors_off=None if m.motors_off is None else [float(v) for v in m.motors_off],
                )
            )
        session = CalibrationSession(
            robot=robot, description=description, T_N=rates.T_N, T_C=rates.T_C, manoeuvres=entries
        )
        header = "# slipnav calibration session (README.md: Calibration sessions)\n"
        (staging / SESSION_FILE).write_text(header + yaml_dump_typed(session))
        os.replace(staging, folder)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return folder / SESSION_FILE


def session_model_path(session_path, out_dir) -> FilePath:
    """``DIR/<session folder>.calibrated.model.yaml`` (``session.yaml`` in ``lab-day``: ``lab-day``), else
    ``DIR/<session file stem>.calibrated.model.yaml``."""
    path = FilePath(session_path)
    name = path.parent.name if path.name == SESSION_FILE and path.parent.name else path.stem
    return FilePath(out_dir) / f"{name.removesuffix('.calibration')}.calibrated.model.yaml"
