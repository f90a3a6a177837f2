"""``slipnav calibrate``'s two commands: a simulated robot's calibration against its truth
(calibrate_command), and a real robot's session (calibrate_session_command); each writes the model and
prints the identified values."""

from __future__ import annotations

import dataclasses as dc
import sys
from pathlib import Path as FilePath

from slipnav.scenarios.model import ModelError, RobotModel, write_model
from slipnav.scenarios.typed_yaml import ScenarioError
from slipnav.studies.calibration import COMPARED, calibrate, compare, simulated_calibration
from slipnav.studies.calibration_session import read_session, session_model_path


def calibrate_command(
    robot_name: str, seeds: list[int], out_dir, stream=None, logs: bool = False, scenario=None
) -> list[dict]:
    """``slipnav calibrate --simulate ROBOT --seed N`` (or ``--seeds N``): drive, identify, write
    ``DIR/<robot>-seed<N>.calibrated.model.yaml`` per seed (``scenario``, ``--simulate SCENARIO.yaml``: its
    plant is the truth, its name replaces the robot's), print identified vs true with the errors in
    standard errors; last line ``calibration worst_radius_pct=.. worst_track_pct=.. worst_gyro_scale_pct=..
    worst_a_peak_pct=.. worst_accel_scale_pct=.. worst_misalignment_deg=.. worst_drag_pct=..`` (scale
    errors absolute, in per cent; misalignments in degrees; the drag's both terms relative). ``logs``:
    also write each seed's session (``DIR/<robot>-seed<N>.calibration/``, logs and session.yaml) and
    identify from reading it back. Returns one row per seed."""
    stream = stream or sys.stdout
    out = FilePath(out_dir)
    rows = []
    name = robot_name if scenario is None else scenario.name
    for seed in seeds:
        session = out / f"{name}-seed{seed}.calibration" if logs else None
        calibration, truth = simulated_calibration(robot_name, seed, session, scenario)
        path = write_model(calibration.model, out / f"{name}-seed{seed}.calibrated.model.yaml")
        rows.append(compare(calibration, truth))
        print(f"{path}", file=stream)
        kinds = {key: kind for key, _, kind in COMPARED}
        for key, (value, true, error, z) in rows[-1].items():
            se = calibration.standard_errors[key]
            shown = f"{error:+.3f} deg" if kinds[key] == "deg" else f"{100 * error:+.3f} %"
            print(
                f"  {key:24s} identified {value:.6g} +- {se:.2g}  true {true:.6g}  "
                f"error {shown} "
                f"({z:+.1f} standard errors)",
                file=stream,
            )
    worst = {
        key: max(abs(row[key][2]) for row in rows) * 100
        for key in (
            "wheel_radius_R",
            "wheel_radius_L",
            "track_width",
            "gyro_scale_error",
            "tyre_peak_acceleration",
            "accel1_scale_error",
            "accel2_scale_error",
            "accel1_misalignment",
            "accel2_misalignment",
            "drag_acceleration",
            "drag_per_speed",
        )
    }
    worst["accel1_misalignment"] /= 100.0  # degrees, not per cent
    worst["accel2_misalignment"] /= 100.0
    print(
        f"calibration worst_radius_pct={max(worst['wheel_radius_R'], worst['wheel_radius_L']):.4f} "
        f"worst_track_pct={worst['track_width']:.4f} worst_gyro_scale_pct={worst['gyro_scale_error']:.4f} "
        f"worst_a_peak_pct={worst['tyre_peak_acceleration']:.3f} "
        f"worst_accel_scale_pct={max(worst['accel1_scale_error'], worst['accel2_scale_error']):.3f} "
        f"worst_misalignment_deg={max(worst['accel1_misalignment'], worst['accel2_misalignment']):.3f} "
        f"worst_drag_pct={max(worst['drag_acceleration'], worst['drag_per_speed']):.2f}",
        file=stream,
    )
    return rows


def calibrate_session_command(session_path, out_dir, stream=None):
    """``slipnav calibrate SESSION.yaml [--out DIR]``: identify from a session's logs and measurements,
    write the model (atomically), print each identified value with its standard error; last line
    ``calibration model=<path>``. Returns the Calibration."""
    stream = stream or sys.stdout
    session, manoeuvres = read_session(session_path)
    base = RobotModel(robot=session.robot, T_N=session.T_N, T_C=session.T_C)
    try:
        calibration = calibrate(manoeuvres, session.robot, base)
    except ModelError as e:
        raise ScenarioError(
            f"calibration session {str(session_path)!r}: its logs and measurements contradict each other: "
            f"they identify {e} (check that each log is its manoeuvre's and the measured poses; README.md: "
            "Calibration sessions)"
        ) from None
    model = dc.replace(
        calibration.model,
        description=f"identified by slipnav calibrate from {str(session_path)!r}"
        + (f" ({session.description})" if session.description else ""),
    )
    path = write_model(model, session_model_path(session_path, out_dir))
    for key, value in calibration.values.items():
        se = calibration.standard_errors.get(key)
        shown = value if isinstance(value, list) else f"{value:.6g}"
        print(f"  {key:24s} {shown}" + (f" +- {se:.2g}" if se is not None else ""), file=stream)
    print(f"calibration model={path}", file=stream)
    return calibration
