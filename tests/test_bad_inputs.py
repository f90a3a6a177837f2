"""A table of user mistakes: command line, scenario YAML and the Python API.

Each case must give exit status 2 with one line on stderr naming the key (command line, YAML), or a
ValueError naming the parameter (Python API), before any simulation starts: the fixture below makes
starting a simulation fail the test.
"""

import dataclasses as dc
import math
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from slipnav.diagrams.closed_loop import ControlSettings, build_closed_loop_diagram
from slipnav.diagrams.open_loop import build_open_loop_diagram
from slipnav.diagrams.records import Belief, Truth
from slipnav.diagrams.robot import make_simulator
from slipnav.scenarios import runner
from slipnav.scenarios.config import load_scenario, scenario_from_yaml
from slipnav.scenarios.run_plan import closed_loop_settings
from slipnav.studies.cli import main
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import tinyphoon
from slipnav.systems.robot.sensors import SensorParameters

STRAIGHT = "trajectory:\n  segments:\n    - !Straight {length: 0.2, v_end: 0.5}\n"
ENC = "sensor_overrides: {encoder_counts_per_revolution: "
PATH = "mode: max_speed\npath:\n  segments:\n    - !Arc {radius: 2.0, angle_deg: 90}\nrobot: kurt3d\n"


@pytest.fixture(autouse=True)
def no_simulation(monkeypatch):
    """Every mistake must be reported before a simulator exists."""

    def refuse(*args, **kwargs):
        raise AssertionError("a simulation was started for a bad input")

    monkeypatch.setattr(runner, "make_simulator", refuse)


# (YAML text, the text the one-line message must contain)
YAML_CASES = [
    ("", "empty"),
    ("# only a comment\n", "empty"),
    ("- 1\n- 2\n", "expected a mapping"),
    ("trajectory: [1, 2\n", "malformed YAML"),
    (STRAIGHT + "seed: 1\nseed: 2\n", "duplicate key 'seed'"),
    (
        "trajectory:\n  segments:\n    - !Straight {length: 1.0, length: 2.0, v_end: 1}\n",
        "duplicate key 'length'",
    ),
    (STRAIGHT + ENC + ".inf}\n", "encoder_counts_per_revolution=inf"),
    (STRAIGHT + ENC + ".nan}\n", "encoder_counts_per_revolution=nan"),
    (STRAIGHT + ENC + "6144.7}\n", "encoder_counts_per_revolution=6144.7"),
    (STRAIGHT + "sensor_overrides: {gyro_noise_std: -1}\n", "gyro_noise_std=-1"),
    (STRAIGHT + "slip_control: {k_s: .inf}\n", "slip_control.k_s=inf"),
    (STRAIGHT + "slip_control: {delta_min: 1.5}\n", "slip_control.delta_min=1.5"),
    (STRAIGHT + "paper: 1\n", "paper: expected bool"),
    (STRAIGHT + "slip_control: {delayed_step_size: 0}\n", "slip_control.delayed_step_size: expected bool"),
    (STRAIGHT + "follower: {use_estimated_speed: no_}\n", "follower.use_estimated_speed: expected bool"),
    (
        STRAIGHT + "navigation: {mixing: {delta_v_running_integral: 1}}\n",
        "delta_v_running_integral: expected bool",
    ),
    (STRAIGHT + "robot_overrides: {mass: 1.0e+6}\n", "mass=1000000.0"),
    (STRAIGHT + "robot_overrides: {mass: 1e6}\n", "mass=1000000.0"),  # YAML 1.1 float accepted, then checked
    (STRAIGHT + "robot_overrides: {tyre_friction: 0.01}\n", "tyre_friction=0.01"),
    (STRAIGHT + "robot_overrides: {tyre_friction: 5}\n", "tyre_friction=5"),
    (STRAIGHT + "robot_overrides: {tyre_friction: 0.1}\n", "tyre_friction=0.1"),  # traction < shoes' drag
    (STRAIGHT + "robot_overrides: {speed_loop_kp: 0}\n", "speed_loop_kp=0"),
    (STRAIGHT + "robot_overrides: {speed_loop_ki: 0}\n", "speed_loop_ki=0"),
    (STRAIGHT + "robot_overrides: {track_width: 1e-6}\n", "track_width=1e-06"),
    (STRAIGHT + "robot_overrides: {wheel_radius: -1}\n", "wheel_radius=-1"),
    (STRAIGHT + "robot_overrides: {wheel_radius: .nan}\n", "wheel_radius=nan"),
    (STRAIGHT + "robot_overrides: {wheel_speed_limit: 10}\n", "wheel_speed_limit=10"),
    (STRAIGHT + "robot_overrides: {name: x}\n", "robot_overrides.name"),
    (STRAIGHT + "follower: {k2: 200}\n", "follower.k2=200"),
    (STRAIGHT + "follower: {k1: 150}\n", "follower.k1=150"),
    (STRAIGHT + "follower: {gamma: .nan}\n", "follower.gamma=nan"),
    ("trajectory:\n  segments:\n    - !Straight {length: 1.0, v_end: 20}\n", "segments[0].v_end=20"),
    ("trajectory:\n  segments:\n    - !Straight {length: 1.0, v_peak: 20}\n", "segments[0].v_peak=20"),
    ("trajectory:\n  initial_speed: 20\n  segments:\n    - !Straight {length: 1.0}\n", "initial_speed=20"),
    ("trajectory:\n  initial_speed: .nan\n  segments:\n    - !Straight {length: 1.0}\n", "initial_speed=nan"),
    (PATH + "path_speed: 4.5\n", "path_speed=4.5"),
    (STRAIGHT + "name: ../x\n", "name='../x'"),
    (STRAIGHT + "name: sub/x\n", "name='sub/x'"),
    (STRAIGHT + "duration: 0.01\n", "duration=0.01"),
    (STRAIGHT + "duration: 1e5\n", "duration=100000.0"),
    ("trajectory:\n  segments:\n    - !Straight {length: 1e5, v_end: 1}\n", "trajectory: the segments are"),
    ("mode: max_speed\npath:\n  segments:\n    - !Straight {length: 1e5}\n", "path: the segments are"),
    (STRAIGHT + "T_N: .nan\n", "T_N=nan"),
    (STRAIGHT + "T_C: 0.021\n", "T_C=0.021"),
    (STRAIGHT + "initial_pose: [0, 0, .nan]\n", "initial_pose"),
    (STRAIGHT + "navigation: {mixing: {b1: .nan}}\n", "mixing.b1=nan"),
    (STRAIGHT + "navigation: {ekf: {Q: [1e-8, .inf, 1e-3, 0.04, 0.04]}}\n", "ekf.Q[1]=inf"),
    (STRAIGHT + "seed: -1\n", "seed=-1"),
    (STRAIGHT + "seed: 2147483648\n", "seed=2147483648"),
    (STRAIGHT + "colour: red\n", "colour is an unknown key"),
    (STRAIGHT + "robot: hal\n", "robot='hal'"),
    (STRAIGHT + "controller: sideways\n", "controller='sideways'"),
    (STRAIGHT + "settle_time: 100\n", "settle_time=100"),
    (STRAIGHT + "standstill_time: 0.01\n", "standstill_time=0.01"),  # not a multiple of T_C
    (STRAIGHT + "standstill_time: -1\n", "standstill_time=-1"),
    (STRAIGHT + "plant_time_step: -1\n", "plant_time_step=-1"),
    (STRAIGHT + "faults: [{kind: dropout, channel: gyro, start: 100.0}]\n", "faults[0].start=100.0"),
    ("trajectory:\n  repeat: 0\n  segments:\n    - !Straight {length: 1.0, v_end: 1}\n", "repeat=0"),
    ("trajectory:\n  segments:\n    - !SpotTurn {angle_deg: 90, duration: 1}\n", "segments[0] (SpotTurn)"),
    ("trajectory:\n  segments:\n    - !Straight {length: 0, v_end: 1}\n", "length=0"),
    ("trajectory:\n  segments:\n    - !Arc {radius: -1, angle_deg: 90, v_end: 1}\n", "radius=-1"),
    ("trajectory:\n  segments:\n    - !Straight {length: 1, v_end: 1, v_peak: 2}\n", "give v_end or v_peak"),
]


@pytest.mark.parametrize("text, message", YAML_CASES)
def test_yaml_mistake_exits_2_with_one_line_naming_the_key(text, message, tmp_path, capsys):
    scenario = tmp_path / "mine.yaml"
    scenario.write_text(text)
    assert main(["run", str(scenario), "--out", str(tmp_path / "out"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert message in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def test_non_utf8_file(tmp_path, capsys):
    scenario = tmp_path / "latin1.yaml"
    scenario.write_bytes(STRAIGHT.encode() + 'description: "Übung"\n'.encode("latin-1"))
    assert main(["run", str(scenario), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "is not UTF-8 text (byte 0xdc" in err and err.count("\n") == 1


def test_yaml_1_1_exponent_floats_are_accepted():
    """The EKF docstring's defaults, written as it writes them, load (YAML 1.1 reads 1e-8 as text)."""
    scenario = scenario_from_yaml(STRAIGHT + "navigation: {ekf: {Q: [1e-8, 1e-8, 1.6e-3, 0.04, 4E-2]}}\n")
    assert scenario.navigation.ekf.Q == [1e-8, 1e-8, 1.6e-3, 0.04, 0.04]


TOO_MANY_SEEDS = "--seeds=1000000000 is out of range: allowed 1 .. 10000"


def _cli_cases(tmp_path):
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    out = ["--out", str(tmp_path / "out")]
    return [
        (["run", "corner", "--out", str(a_file)], "--out="),
        (["run", "corner", "--out", str(a_file / "sub")], "--out="),
        (["run", "corner", "--duration", "0.001", *out], "--duration=0.001"),
        (["run", "corner", "--duration", "1e6", *out], "--duration=1000000.0"),
        (["run", "corner", "--duration", "nan", *out], "--duration=nan"),
        (["run", "corner", "--duration", "inf", *out], "--duration=inf"),
        (["run", "corner", "--seed", "-1", *out], "--seed=-1"),
        (["run", "corner", "--seed", "2147483648", *out], "--seed=2147483648"),
        (["run", "corner", "--seed", "abc", *out], "--seed"),
        (["run", "corner", "--speed-law", "constant", *out], "--speed-law"),
        (["run", "corner", "--speed-law", "fast", *out], "--speed-law"),
        (["run", "circle", "--no-slip-control", *out], "--no-slip-control"),
        (["run", "corner", "--open-loop", "--no-slip-control", *out], "--no-slip-control"),
        (["run", "circle", "--open-loop", "--speed-law", "bounded", *out], "--speed-law"),
        (["run", "nosuch", *out], "'nosuch'"),
        (["run", str(tmp_path / "missing.yaml"), *out], "missing.yaml"),
        (["run", *out], "scenario"),
        (["fly"], "'fly'"),
        (["accuracy", "corner", "--seeds", "0"], "--seeds=0"),
        (["accuracy", "corner", "--duration", "0.001"], "--duration=0.001"),
        (["error-budget", "corner", "--seeds", "0"], "--seeds=0"),
        (["bench", "corner", "--repeat", "0"], "--repeat=0"),
        (["bench", "nowhere"], "'nowhere'"),
        (["diagram", "nothing"], "diagram 'nothing'"),
        (["diagram", "closed_loop", "--out", str(tmp_path / "x.gif")], "--out"),
        (["accuracy", "corner", "--seeds", "1000000000"], TOO_MANY_SEEDS),
        (["robustness", "corner", "--seeds", "1000000000"], TOO_MANY_SEEDS),
        (["sweep", "corner", "--seeds", "1000000000"], TOO_MANY_SEEDS),
        (["error-budget", "--seeds", "1000000000"], TOO_MANY_SEEDS),
        (["faults", "--seeds", "1000000000"], TOO_MANY_SEEDS),
        (["accuracy", "corner", "--scheduler", "not an address", *out], "--scheduler='not an address'"),
        (["sweep", "corner", "--scheduler", "http://127.0.0.1:8786", *out], "allowed [tcp|tls|ws|wss://]"),
        (["accuracy", "corner", "--scheduler", "tcp://", *out], "--scheduler='tcp://' is not an address"),
    ]


CLI_CASE_COUNT = 33


@pytest.mark.parametrize("index", range(CLI_CASE_COUNT))
def test_command_line_mistake_exits_2_with_one_line_naming_the_flag(index, tmp_path, capsys):
    cases = _cli_cases(tmp_path)
    assert len(cases) == CLI_CASE_COUNT
    argv, message = cases[index]
    try:
        status = main(argv)
    except SystemExit as e:  # argparse's own mistakes (bad int, unknown choice)
        status = e.code
    assert status == 2, argv
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and err.count("\n") == 1, err
    assert message in err, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


def _open_loop_inputs():
    return dict(
        truth=Truth(sensors=SensorParameters(), seed=0),
        belief=Belief(robot=tinyphoon(), rates=SampleRates()),
        wheel_speeds=np.zeros((10, 2)),
        reference_poses=np.zeros((10, 3)),
    )


def _closed_loop_inputs():
    scenario = load_scenario("corner")
    control, _, _ = closed_loop_settings(scenario, True, "bounded")
    return dict(
        truth=Truth(sensors=SensorParameters(), seed=0),
        belief=Belief(robot=tinyphoon(), rates=SampleRates(), navigation=NavigationParameters()),
        control=control,
    )


SLIPPERY, NO_KI = tinyphoon().replace(tyre_friction=0.01), tinyphoon().replace(speed_loop_ki=0.0)
API_CASES = [
    ("open", "belief", dict(robot=None), "belief.robot"),
    ("open", "belief", dict(robot=SLIPPERY), "belief.robot.tyre_friction=0.01"),
    ("open", "belief", dict(robot=NO_KI), "belief.robot.speed_loop_ki=0.0"),
    ("open", "truth", dict(sensors=None), "truth.sensors"),
    ("open", "belief", dict(rates=None), "belief.rates"),
    ("open", "truth", dict(seed=None), "truth.seed=None"),
    ("open", "truth", dict(seed=-3), "truth.seed=-3"),
    ("open", "truth", dict(initial_speed=math.nan), "truth.initial_speed=nan"),
    ("open", "truth", dict(initial_speed=50.0), "truth.initial_speed=50.0"),
    ("open", "truth", dict(initial_pose=(0.0, math.nan, 0.0)), "truth.initial_pose"),
    ("open", None, dict(wheel_speeds=np.full((10, 2), math.nan)), "wheel_speeds"),
    ("open", None, dict(wheel_speeds=np.zeros((10, 3))), "wheel_speeds"),
    ("open", None, dict(wheel_speeds=np.full((10, 2), 99.0)), "wheel_speeds"),
    ("open", None, dict(reference_poses=np.zeros((9, 3))), "reference_poses"),
    ("open", "belief", dict(navigation="ekf"), "belief.navigation"),
    ("open", "truth", dict(plant_time_step=math.nan), "truth.plant_time_step=nan"),
    ("open", None, dict(truth=None), "truth must be a Truth"),
    ("closed", None, dict(belief=None), "belief must be a Belief"),
    ("closed", "belief", dict(navigation=None), "belief.navigation"),
    ("closed", None, dict(control=None), "control"),
    ("closed", "truth", dict(seed=None), "truth.seed=None"),
    ("closed", "belief", dict(robot=None), "belief.robot"),
]


@pytest.mark.parametrize("builder, record, change, message", API_CASES)
def test_builder_mistake_raises_value_error_naming_the_parameter(builder, record, change, message):
    """A wrong field of the Truth or Belief (``record``) or a wrong argument (None) names itself."""
    inputs = _open_loop_inputs() if builder == "open" else _closed_loop_inputs()
    if record is None:
        inputs.update(change)
    else:
        inputs[record] = dc.replace(inputs[record], **change)
    build = build_open_loop_diagram if builder == "open" else build_closed_loop_diagram
    with pytest.raises(ValueError) as e:
        build(**inputs)
    assert message in str(e.value)


def test_builder_rejects_a_control_without_follower():
    inputs = _closed_loop_inputs()
    inputs["control"] = ControlSettings(mode="trajectory", path=inputs["control"].path, follower=None)
    with pytest.raises(ValueError, match="control.follower"):
        build_closed_loop_diagram(**inputs)


@pytest.mark.parametrize(
    "call, message",
    [
        (lambda: make_simulator(None, None, 0.001), "seed=None"),
        (lambda: runner.run_scenario(None), "scenario must be a Scenario"),
        (lambda: runner.run_scenario(load_scenario("corner"), seed=1.5), "--seed=1.5"),
        (lambda: runner.run_scenario(load_scenario("corner"), duration=0.0), "--duration=0.0"),
        (lambda: runner.run_scenario(load_scenario("corner"), speed_law="constant"), "speed_law"),
        (lambda: runner.run_scenario(load_scenario("circle"), slip_control=False), "slip_control"),
        (lambda: runner.run_scenario(_without_follower()), "follower=None"),
        (lambda: tinyphoon().replace(wheel_radius=-1.0), "wheel_radius=-1.0"),
        (lambda: tinyphoon().replace(wheel_radius=math.nan), "wheel_radius=nan"),
        (lambda: tinyphoon().replace(track_width=0.0), "track_width=0.0"),
        (lambda: load_scenario(None), "scenario=None"),
        (lambda: scenario_from_yaml("# nothing here\n"), "empty"),
    ],
)
def test_python_api_mistake_raises_value_error_naming_the_parameter(call, message):
    with pytest.raises(ValueError) as e:
        call()
    assert message in str(e.value)


def _without_follower():
    scenario = load_scenario("corner")
    scenario.follower = None
    return scenario


def test_installed_command_reports_a_mistake_without_traceback(tmp_path):
    """The real console script (a subprocess): one line, exit status 2."""
    scenario = tmp_path / "bad.yaml"
    scenario.write_text(STRAIGHT + "robot_overrides: {tyre_friction: 0.01}\n")
    done = subprocess.run(
        [sys.executable, "-m", "slipnav.studies.cli", "run", str(scenario), "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 2
    assert done.stderr.startswith("slipnav: error: robot_overrides.tyre_friction=0.01")
    assert done.stderr.count("\n") == 1 and "Traceback" not in done.stderr


def test_ctrl_c_during_a_run_exits_130_with_one_line_and_no_files(tmp_path):
    """SIGINT while simulating: ``slipnav: interrupted``, status 130, nothing written."""
    process = subprocess.Popen(
        [sys.executable, "-m", "slipnav.studies.cli", "run", "long_path", "--out", str(tmp_path / "out")],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    deadline = time.monotonic() + 60
    while not (tmp_path / "out").exists() and time.monotonic() < deadline:  # --out is checked first
        time.sleep(0.05)
    time.sleep(1.0)  # now inside the simulation (long_path takes several seconds)
    assert process.poll() is None
    os.kill(process.pid, signal.SIGINT)
    out, err = process.communicate(timeout=60)
    assert process.returncode == 130
    assert err == "slipnav: interrupted\n"
    assert list((tmp_path / "out").iterdir()) == []
