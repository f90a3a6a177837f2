"""Scenario files: a typed YAML schema loaded with Drake's ``yaml_load_typed``, checked strictly.

Unknown keys, wrong types, unknown segment tags and malformed YAML raise ScenarioError naming the key
(e.g. ``trajectory.segments[2].length``). Values are range-checked when the scenario is built.
"""

import dataclasses as dc
import math
import types
import typing
from pathlib import Path as FilePath

from pydrake.common.yaml import yaml_load_data, yaml_load_typed
from slipnav.scenarios.tolerances import (
    TOLERANCE_PRESET,
    PlantTruth,
    apply_deviations,
    draw_deviations,
)
from slipnav.scenarios.trajectories import PathConfig, TrajectoryConfig
from slipnav.systems.navigation import NavigationParameters
from slipnav.systems.path_follower import PathFollowerParameters
from slipnav.systems.plant import DEFAULT_TIME_STEP, ROBOTS, RobotParameters, robot_parameters, substeps_per
from slipnav.systems.rates import SampleRates
from slipnav.systems.sensors import SensorParameters, default_sensor_parameters
from slipnav.systems.slip_control import StepSizeParameters

BUILTIN_DIR = FilePath(__file__).resolve().parent / "builtin"
MODES = ("trajectory", "max_speed")
CONTROLLERS = ("closed_loop", "feedforward")
SPEED_LAWS = ("bounded", "constant")


class ScenarioError(ValueError):
    """A scenario that cannot be loaded or built; the message names the offending key."""


@dc.dataclass
class Scenario:
    """One simulated experiment.

    Args:
        name: label; defaults to the file's stem.
        description: one line for ``slipnav list``.
        robot: reference robot, ``tinyphoon`` or ``kurt3d``: the nominal model (data sheet, tape measure)
            that navigation and control believe, and the plant unless ``plant`` says otherwise.
        robot_overrides: RobotParameters fields to change in the nominal model, e.g. ``{mass: 0.45}``.
        sensor_overrides: SensorParameters fields to change in the nominal model.
        plant: how the simulated robot really differs from the nominal model (PlantTruth: plant-only
            overrides, fixed deviations, tolerances drawn from the seed; scenarios/tolerances.py).
        plant_time_step: semi-implicit integration step of the discrete plant (s), dividing T_N and the
            robot's speed-loop period; 0 integrates the continuous plant with error-controlled RK3
            (accurate, ~20x slower). Default 0.5 ms (accuracy: systems.plant.DEFAULT_TIME_STEP).
        T_N: navigation period (s). T_C: control period (s), an integer multiple of T_N.
        seed: seed of all sensor noise.
        mode: ``trajectory`` (Seyr: timed trajectory) or ``max_speed`` (Indiveri: geometric path).
        trajectory: segments of the timed trajectory (mode trajectory).
        path: segments of the geometric path (mode max_speed).
        path_speed: speed of the open-loop run along a path (m/s); default V_m/2.
        initial_pose: [x, y, phi] of the robot at t = 0 (m, m, rad); the reference starts at the origin.
        settle_time: simulated time after the reference ends (s).
        duration: hard limit of the simulated time (s); default: reference end + settle_time.
        controller: ``closed_loop`` (navigation -> path follower -> plant) or ``feedforward`` (the
            trajectory's wheel speeds played open loop; navigation still runs).
        follower: Lyapunov path follower gains (PathFollowerParameters).
        slip_control: step-size controller tuning (StepSizeParameters), trajectory mode.
        slip_control_enabled: False keeps the step size at 1.
        speed_law: ``bounded`` (Indiveri I(24)) or ``constant`` (u = V_m/2), max_speed mode.
        navigation: tuning of the navigation blocks (NavigationParameters: ekf, mixing, sideslip,
            gyrodometry), e.g. ``navigation: {mixing: {b1: 0.05}}``.
    """

    name: str = ""
    description: str = ""
    robot: str = "tinyphoon"
    robot_overrides: dict[str, float] = dc.field(default_factory=dict)
    sensor_overrides: dict[str, float] = dc.field(default_factory=dict)
    plant: PlantTruth = dc.field(default_factory=PlantTruth)
    plant_time_step: float = DEFAULT_TIME_STEP
    T_N: float = 0.002
    T_C: float = 0.02
    seed: int = 0
    mode: str = "trajectory"
    trajectory: TrajectoryConfig | None = None
    path: PathConfig | None = None
    path_speed: float | None = None
    initial_pose: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0])
    settle_time: float = 0.5
    duration: float | None = None
    navigation: NavigationParameters = dc.field(default_factory=NavigationParameters)
    controller: str = "closed_loop"
    follower: PathFollowerParameters = dc.field(default_factory=PathFollowerParameters)
    slip_control: StepSizeParameters = dc.field(default_factory=StepSizeParameters)
    slip_control_enabled: bool = True
    speed_law: str = "bounded"

    # -- derived, validated objects -----------------------------------------------------------------
    def rates(self) -> SampleRates:
        return _wrap(lambda: SampleRates(T_N=self.T_N, T_C=self.T_C))

    def robot_parameters(self) -> RobotParameters:
        if self.robot not in ROBOTS:
            raise ScenarioError(f"robot={self.robot!r} is unknown: allowed {sorted(ROBOTS)}")
        base = robot_parameters(self.robot)
        return _wrap(lambda: _override(base, self.robot_overrides, "robot_overrides"))

    def sensor_parameters(self) -> SensorParameters:
        base = default_sensor_parameters(self.robot)
        return _wrap(lambda: _override(base, self.sensor_overrides, "sensor_overrides"))

    def plant_parameters(self, seed: int | None = None, tolerances: bool = False):
        """The simulated robot as it really is: (RobotParameters, SensorParameters, drawn deviations).

        The nominal model with ``plant.robot_overrides`` / ``plant.sensor_overrides``, then the fixed
        ``plant.deviations`` plus draws within ``plant.tolerances`` (or, with ``tolerances``, within
        TOLERANCE_PRESET where the scenario sets no bound) from ``seed`` (default the scenario's).
        """
        truth = self.plant
        if tolerances:
            bounds = {
                f.name: getattr(truth.tolerances, f.name) or getattr(TOLERANCE_PRESET, f.name)
                for f in dc.fields(TOLERANCE_PRESET)
            }
            truth = dc.replace(truth, tolerances=dc.replace(truth.tolerances, **bounds))
        _wrap(truth.validate)
        robot = _prefixed(
            lambda: _override(self.robot_parameters(), truth.robot_overrides, "plant.robot_overrides"),
            "plant.robot_overrides",
        )
        sensors = _prefixed(
            lambda: _override(self.sensor_parameters(), truth.sensor_overrides, "plant.sensor_overrides"),
            "plant.sensor_overrides",
        )
        deviations = draw_deviations(truth, self.seed if seed is None else seed)
        plant, true_sensors = _prefixed(lambda: apply_deviations(robot, sensors, deviations), "plant")
        return plant, true_sensors, deviations

    def validate(self) -> "Scenario":
        """Check every value that the schema cannot; returns self."""
        self.rates()
        self.robot_parameters()
        self.sensor_parameters()
        self.plant_parameters()
        _wrap(self.navigation.validate)
        _wrap(self.follower.__post_init__)
        _wrap(self.slip_control.__post_init__)
        if self.controller not in CONTROLLERS:
            raise ScenarioError(f"controller={self.controller!r} is unknown: allowed {list(CONTROLLERS)}")
        if self.speed_law not in SPEED_LAWS:
            raise ScenarioError(f"speed_law={self.speed_law!r} is unknown: allowed {list(SPEED_LAWS)}")
        if self.mode not in MODES:
            raise ScenarioError(f"mode={self.mode!r} is unknown: allowed {list(MODES)}")
        if self.mode == "trajectory" and self.trajectory is None:
            raise ScenarioError("mode 'trajectory' needs a 'trajectory' with segments")
        if self.mode == "max_speed" and self.path is None:
            raise ScenarioError("mode 'max_speed' needs a 'path' with segments")
        if self.trajectory is not None and self.path is not None:
            raise ScenarioError("give either 'trajectory' or 'path', not both")
        if len(self.initial_pose) != 3 or not all(math.isfinite(v) for v in self.initial_pose):
            raise ScenarioError(f"initial_pose={self.initial_pose!r} must be three finite numbers")
        if not (math.isfinite(self.settle_time) and 0.0 <= self.settle_time <= 60.0):
            raise ScenarioError(f"settle_time={self.settle_time!r} is out of range: allowed [0, 60] s")
        if self.duration is not None and not (0.0 < self.duration <= 3600.0):
            raise ScenarioError(f"duration={self.duration!r} is out of range: allowed (0, 3600] s")
        if self.path_speed is not None and not (0.0 < self.path_speed <= 10.0):
            raise ScenarioError(f"path_speed={self.path_speed!r} is out of range: allowed (0, 10] m/s")
        if not (0 <= self.seed < 2**31):
            raise ScenarioError(f"seed={self.seed!r} is out of range: allowed 0 .. 2**31-1")
        if not (math.isfinite(self.plant_time_step) and 0.0 <= self.plant_time_step <= 0.01):
            raise ScenarioError(
                f"plant_time_step={self.plant_time_step!r} is out of range: "
                "allowed 0 (continuous) or (0, 0.01] s"
            )
        if self.plant_time_step > 0.0:
            period = self.robot_parameters().speed_loop_period
            _wrap(lambda: substeps_per(self.T_N, self.plant_time_step, "T_N"))
            _wrap(lambda: substeps_per(period, self.plant_time_step, "speed_loop_period"))
        return self


def _wrap(make):
    try:
        return make()
    except ScenarioError:
        raise
    except (ValueError, TypeError) as e:
        raise ScenarioError(str(e)) from None


def _prefixed(make, where: str):
    """make(), a ValueError naming its key as ``where.key``."""
    try:
        return make()
    except ScenarioError:
        raise
    except (ValueError, TypeError) as e:
        message = str(e)
        if not message.startswith(where.split(".")[0] + "."):
            message = f"{where}.{message}"
        raise ScenarioError(message) from None


def _override(base, overrides: dict[str, float], where: str):
    names = {f.name for f in dc.fields(base)}
    for key in overrides:
        if key not in names or key == "name":
            raise ScenarioError(f"{where}.{key} is unknown: allowed {sorted(names - {'name'})}")
    changes = {}
    for key, value in overrides.items():
        current = getattr(base, key)
        changes[key] = int(value) if isinstance(current, int) else value
    return dc.replace(base, **changes)


# ---------------------------------------------------------------------------------------------------
# Strict structural check of raw YAML data against the dataclass schema (names the key path).


def _type_name(t) -> str:
    return getattr(t, "__name__", str(t))


def _check(schema, data, where: str):
    origin = typing.get_origin(schema)
    args = typing.get_args(schema)
    if origin in (typing.Union, types.UnionType):
        if data is None and type(None) in args:
            return
        options = [a for a in args if a is not type(None)]
        if len(options) == 1:
            return _check(options[0], data, where)
        if not isinstance(data, dict) or "_tag" not in data:
            tags = ", ".join("!" + _type_name(a) for a in options)
            raise ScenarioError(f"{where}: needs a type tag, one of {tags}")
        tag = data["_tag"].lstrip("!")
        for option in options:
            if _type_name(option) == tag:
                return _check(option, {k: v for k, v in data.items() if k != "_tag"}, where)
        tags = ", ".join("!" + _type_name(a) for a in options)
        raise ScenarioError(f"{where}: type tag !{tag} is unknown: allowed {tags}")
    if origin in (list, list):
        if not isinstance(data, list):
            raise ScenarioError(f"{where}: expected a list, got {data!r}")
        for i, item in enumerate(data):
            _check(args[0], item, f"{where}[{i}]")
        return
    if origin in (dict, dict):
        if not isinstance(data, dict):
            raise ScenarioError(f"{where}: expected a mapping, got {data!r}")
        for key, value in data.items():
            _check(args[1], value, f"{where}.{key}")
        return
    if dc.is_dataclass(schema):
        if not isinstance(data, dict):
            raise ScenarioError(f"{where or 'scenario'}: expected a mapping, got {data!r}")
        hints = typing.get_type_hints(schema)
        for key, value in data.items():
            path = f"{where}.{key}" if where else str(key)
            if key == "_tag":
                continue
            if key not in hints:
                raise ScenarioError(f"{path} is an unknown key: allowed {sorted(hints)}")
            _check(hints[key], value, path)
        return
    if schema is float:
        ok = isinstance(data, (int, float)) and not isinstance(data, bool)
    elif schema is int:
        ok = isinstance(data, int) and not isinstance(data, bool)
    elif schema is bool:
        ok = isinstance(data, bool)
    elif schema is str:
        ok = isinstance(data, str)
    else:
        ok = True
    if not ok:
        raise ScenarioError(f"{where}: expected {_type_name(schema)}, got {data!r}")


def scenario_from_yaml(text: str, name: str = "") -> Scenario:
    """Parse and validate a scenario from YAML text."""
    try:
        raw = yaml_load_data(text)
    except Exception as e:  # yaml.YAMLError and friends
        raise ScenarioError(f"malformed YAML: {str(e).splitlines()[0]}") from None
    if raw is None:
        raw = {}
    _check(Scenario, raw, "")
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text)
    except Exception as e:
        raise ScenarioError(str(e)) from None
    if not scenario.name:
        scenario.name = name
    return scenario.validate()


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package."""
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.yaml"))


def load_scenario(name_or_path: str) -> Scenario:
    """A built-in scenario by name, or a scenario YAML file by path."""
    path = FilePath(name_or_path)
    if path.suffix in (".yaml", ".yml") or path.exists():
        if not path.is_file():
            raise ScenarioError(f"scenario file {name_or_path!r} does not exist")
        return scenario_from_yaml(path.read_text(), name=path.stem)
    if name_or_path not in builtin_scenarios():
        raise ScenarioError(
            f"scenario {name_or_path!r} is neither a built-in ({', '.join(builtin_scenarios())}) "
            "nor a .yaml file"
        )
    return scenario_from_yaml((BUILTIN_DIR / f"{name_or_path}.yaml").read_text(), name=name_or_path)
