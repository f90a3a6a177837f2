"""Scenario files: a typed YAML schema loaded with Drake's ``yaml_load_typed``, checked strictly.

Unknown keys, wrong types, unknown segment tags and malformed YAML raise ScenarioError naming the key
(e.g. ``trajectory.segments[2].length``). Values are range-checked when the scenario is built.
"""

import dataclasses as dc
import math
from pathlib import Path as FilePath

from pydrake.common.yaml import yaml_load_typed
from slipnav.diagrams.closed_loop import LOCALISATION_SOURCES
from slipnav.diagrams.records import Belief
from slipnav.scenarios.model import ModelError, load_model
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.tolerances import (
    TOLERANCE_PRESET,
    PlantTruth,
    apply_deviations,
    draw_deviations,
)
from slipnav.scenarios.trajectories import (
    PathConfig,
    TrajectoryConfig,
    check_path_size,
    check_trajectory_size,
)
from slipnav.scenarios.typed_yaml import (
    ScenarioError,
    check_field_types,
    check_schema,
    key_steps,
    load_yaml,
    replaced_at,
)
from slipnav.systems.checks import check_follower_gains, check_robot_physics, check_start_time
from slipnav.systems.control.path_follower import PathFollowerParameters
from slipnav.systems.control.slip_control import StepSizeParameters
from slipnav.systems.health.perturbation import PerturbationParameters
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.dynamics import substeps_per
from slipnav.systems.robot.faults import FaultEvent, check_fault_events
from slipnav.systems.robot.parameters import ROBOTS, RobotParameters, robot_parameters
from slipnav.systems.robot.plant import DEFAULT_TIME_STEP
from slipnav.systems.robot.sensors import SensorParameters, default_sensor_parameters

BUILTIN_DIR = FilePath(__file__).resolve().parent / "builtin"
MODES = ("trajectory", "max_speed")
CONTROLLERS = ("closed_loop", "feedforward")
SPEED_LAWS = ("bounded", "constant")


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
            (accurate, ~20x slower). Default 0.5 ms (accuracy: systems.robot.plant.DEFAULT_TIME_STEP).
        T_N: navigation period (s). T_C: control period (s), an integer multiple of T_N.
        seed: seed of all sensor noise.
        mode: ``trajectory`` (Seyr: timed trajectory) or ``max_speed`` (Indiveri: geometric path).
        trajectory: segments of the timed trajectory (mode trajectory).
        path: segments of the geometric path (mode max_speed).
        path_speed: speed of the open-loop run along a path (m/s); default V_m/2.
        initial_pose: [x, y, phi] of the robot at t = 0 (m, m, rad); the reference starts at the origin.
        standstill_time: the robot stands this long before the controller starts (s, a multiple of
            T_C), as a real robot does while its navigation initialises: the yaw calibration learns the
            gyro's bias there (systems/navigation/yaw_calibration.py). Only where the run starts at rest.
        settle_time: simulated time after the reference ends (s).
        duration: hard limit of the simulated time (s); default: reference end + settle_time.
        controller: ``closed_loop`` (navigation -> path follower -> plant) or ``feedforward`` (the
            trajectory's wheel speeds played open loop; navigation still runs).
        follower: Lyapunov path follower gains (PathFollowerParameters).
        slip_control: step-size controller tuning (StepSizeParameters), trajectory mode.
        slip_control_enabled: False keeps the step size at 1.
        speed_law: ``bounded`` (Indiveri I(24)) or ``constant`` (u = V_m/2), max_speed mode.
        localisation: what the follower localises by (Indiveri et al. Fig. 6): ``fused`` (the
            navigation's estimate), ``odometry``, ``gyrodometry`` or ``truth`` (an oracle).
        navigation: tuning of the navigation blocks (NavigationParameters: ekf, mixing, sideslip,
            gyrodometry, yaw_calibration, health, standstill), e.g. ``navigation: {mixing: {b1: 0.05}}``.
        faults: timed sensor faults between the sensors and the navigation (systems/robot/faults.py
            FaultEvent: kind, channel, start, duration, value), e.g. ``faults: [{kind: dropout,
            channel: gyro, start: 2.0, duration: 0.5}]``.
        perturbation_monitor: thresholds of the perturbation flags (systems/health/perturbation.py: a
            wheel held, pushed or lifted, the body pushed), from the wheel commands, the encoders and the
            navigation's estimate.
        paper: the papers' equations exactly as printed, every extension off (scenarios/paper.py
            paper_mode, applied on top of the other keys when the scenario is loaded or run; README:
            Paper mode).
        model: a model YAML (scenarios/model.py; e.g. one ``slipnav calibrate`` wrote): what navigation
            and control believe, refining the nominal ``robot``: its ``robot_overrides`` and
            ``sensor_overrides`` over the scenario's, its ``calibration`` removed from every sensor
            sample, its navigation keys over the scenario's ``navigation``. The plant stays the
            scenario's. A relative path is read from the scenario file's folder (``slipnav run
            --model``: from the working directory).
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
    standstill_time: float = 1.0
    settle_time: float = 0.5
    duration: float | None = None
    navigation: NavigationParameters = dc.field(default_factory=NavigationParameters)
    controller: str = "closed_loop"
    follower: PathFollowerParameters = dc.field(default_factory=PathFollowerParameters)
    slip_control: StepSizeParameters = dc.field(default_factory=StepSizeParameters)
    slip_control_enabled: bool = True
    speed_law: str = "bounded"
    localisation: str = "fused"
    faults: list[FaultEvent] = dc.field(default_factory=list)
    perturbation_monitor: PerturbationParameters = dc.field(default_factory=PerturbationParameters)
    paper: bool = False
    model: str | None = None

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

    def robot_model(self):
        """The RobotModel of the ``model`` key (None without); ScenarioError naming ``model`` and the key
        of the model file, or the model's robot or periods where they differ from the scenario's."""
        if self.model is None:
            return None
        try:
            model = load_model(self.model)
        except ModelError as e:
            raise ScenarioError(f"model: {e}") from None
        if model.robot != self.robot:
            raise ScenarioError(
                f"model: the model file {self.model!r} describes robot {model.robot!r}, the scenario "
                f"robot {self.robot!r}: allowed a model of the same robot"
            )
        for key in ("T_N", "T_C"):
            if getattr(model, key) != getattr(self, key):
                raise ScenarioError(
                    f"model: the model file's {key}={getattr(model, key)!r} differs from the scenario's "
                    f"{key}={getattr(self, key)!r}: allowed the same periods"
                )
        return model

    def belief(self) -> Belief:
        """What navigation and control read (diagrams.records.Belief): the nominal robot, its sensors' data
        sheet and the navigation tuning, each refined by the ``model`` (paper mode applied last), the
        model's calibration (none without), the periods and the perturbation monitor's tuning."""
        model = self.robot_model()
        robot, sensors, navigation = self.robot_parameters(), self.sensor_parameters(), self.navigation
        calibration = SensorCalibration()
        if model is not None:
            robot = _wrap(lambda: _override(robot, model.robot_overrides, "model.robot_overrides"))
            sensors = _wrap(lambda: _override(sensors, model.sensor_overrides, "model.sensor_overrides"))
            navigation = _wrap(lambda: model.navigation_over(navigation))
            calibration = model.calibration
            if self.paper:
                navigation = paper_mode(dc.replace(self, navigation=navigation, model=None)).navigation
        return Belief(
            robot=robot,
            rates=self.rates(),
            navigation=navigation,
            sensors=sensors,
            calibration=calibration,
            perturbation_monitor=self.perturbation_monitor,
            model=model,
        )

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
        robot = _wrap(
            lambda: _override(self.robot_parameters(), truth.robot_overrides, "plant.robot_overrides"),
            "plant.robot_overrides",
        )
        sensors = _wrap(
            lambda: _override(self.sensor_parameters(), truth.sensor_overrides, "plant.sensor_overrides"),
            "plant.sensor_overrides",
        )
        deviations = draw_deviations(truth, self.seed if seed is None else seed)
        plant, true_sensors = _wrap(lambda: apply_deviations(robot, sensors, deviations), "plant")
        return plant, true_sensors, deviations

    def validate(self) -> "Scenario":
        """Check every value that the schema cannot; returns self."""
        check_field_types(self, "")
        self.rates()
        self.robot_parameters()
        self.sensor_parameters()
        _wrap(self.navigation.validate)
        _wrap(self.follower.__post_init__)
        _wrap(self.slip_control.__post_init__)
        _wrap(self.perturbation_monitor.validate)
        if self.controller not in CONTROLLERS:
            raise ScenarioError(f"controller={self.controller!r} is unknown: allowed {list(CONTROLLERS)}")
        if self.localisation not in LOCALISATION_SOURCES:
            raise ScenarioError(
                f"localisation={self.localisation!r} is unknown: allowed {list(LOCALISATION_SOURCES)}"
            )
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
        _wrap(lambda: check_start_time(self.standstill_time, self.T_C, "standstill_time"))
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
        _wrap(lambda: check_fault_events(self.faults))
        self.belief()
        check_plausible(self)
        self.plant_parameters()  # after the seed check: the draw needs a valid seed
        return self


def _wrap(make, where: str | None = None):
    """make(), its ValueError as a ScenarioError; with ``where``, naming its key as ``where.key``."""
    try:
        return make()
    except ScenarioError:
        raise
    except (ValueError, TypeError) as e:
        message = str(e)
        if where is not None and not message.startswith(where.split(".")[0] + "."):
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
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ScenarioError(f"{where}.{key}={value!r} is out of range: allowed finite numbers")
        if isinstance(current, int):
            if value != int(value):
                raise ScenarioError(f"{where}.{key}={value!r} is out of range: allowed integers")
            value = int(value)
        changes[key] = value
    return dc.replace(base, **changes)


def scenario_from_yaml(text: str, name: str = "", folder=None) -> Scenario:
    """Parse and validate a scenario from YAML text; ``folder``: where a relative ``model`` path is
    read from (the scenario file's folder; default the working directory)."""
    raw = load_yaml(text)
    if raw is None:
        raise ScenarioError(
            "the scenario is empty (no keys, or comments only): give at least 'trajectory: {segments: "
            "[...]}' or 'mode: max_speed' with 'path: {segments: [...]}' (docs/scenario-schema.md)"
        )
    if not isinstance(raw, dict):
        raise ScenarioError(f"scenario: expected a mapping of keys (docs/scenario-schema.md), got {raw!r}")
    check_schema(Scenario, raw, "")
    try:
        scenario = yaml_load_typed(schema=Scenario, data=text)
    except Exception as e:
        raise ScenarioError(str(e)) from None
    if not scenario.name:
        scenario.name = name
    if scenario.model is not None and folder is not None and not FilePath(scenario.model).is_absolute():
        scenario.model = str(FilePath(folder) / scenario.model)
    return with_paper_mode(scenario.validate())


def with_paper_mode(scenario: Scenario) -> Scenario:
    """``scenario``, in paper mode (scenarios/paper.py) when its ``paper`` key is true."""
    if not scenario.paper:
        return scenario
    return paper_mode(scenario)


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped with the package."""
    return sorted(p.stem for p in BUILTIN_DIR.glob("*.yaml"))


def load_scenario(name_or_path: str) -> Scenario:
    """A built-in scenario by name, or a scenario YAML file by path."""
    if not isinstance(name_or_path, (str, FilePath)):
        raise ScenarioError(f"scenario={name_or_path!r}: allowed a built-in name or a .yaml path")
    path = FilePath(name_or_path)
    if path.suffix in (".yaml", ".yml") or path.exists():
        if not path.is_file():
            raise ScenarioError(f"scenario file {str(name_or_path)!r} does not exist")
        try:
            data = path.read_bytes()
        except OSError as e:
            raise ScenarioError(f"scenario file {str(name_or_path)!r} cannot be read: {e.strerror}") from None
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as e:
            raise ScenarioError(
                f"scenario file {str(name_or_path)!r} is not UTF-8 text (byte 0x{data[e.start]:02x} at "
                f"offset {e.start}): allowed UTF-8 YAML"
            ) from None
        return scenario_from_yaml(text, name=path.stem, folder=path.parent)
    if name_or_path not in builtin_scenarios():
        raise ScenarioError(
            f"scenario {name_or_path!r} is neither a built-in ({', '.join(builtin_scenarios())}) "
            "nor a .yaml file"
        )
    return scenario_from_yaml((BUILTIN_DIR / f"{name_or_path}.yaml").read_text(), name=name_or_path)


# ---------------------------------------------------------------------------------------------------
# Checks across keys: physically impossible or unusable settings (end of Scenario.validate).

MAX_DURATION = 3600.0
"""Longest simulated time (s), for the YAML ``duration`` and ``--duration`` alike."""
MIN_CONTROL_PERIODS = 5
"""Shortest simulated time, in control periods T_C."""
INFINITY_ALLOWED = {
    "navigation.mixing.tyre_peak_acceleration",
    "navigation.mixing.gyro_turn_rate",
    "navigation.mixing.tyre_model_gate_deg",
    "navigation.mixing.slide_onset_jump",
    "navigation.gyro_bias.averaging_time",
    "navigation.health.stuck_braking_deceleration",
    "navigation.health.fast_consistency_factor",
    "perturbation_monitor.force_threshold",
    "perturbation_monitor.slide_threshold",
    "perturbation_monitor.slide_demand",
    "perturbation_monitor.push_demand",
}
"""Float keys where .inf means something (no tyre curve; no gyro turn rule; no tyre-model check; no
slide-onset test; a never-forgetting average; a stuck test at any braking; no fast pair test; no force
test; no slide test; a slide test at any demand; a sideways push taken at any demand)."""


def check_duration(scenario: Scenario, duration, where: str = "--duration") -> float:
    """A simulated time in [5 T_C, 3600] s."""
    low = MIN_CONTROL_PERIODS * scenario.T_C
    ok = isinstance(duration, (int, float)) and not isinstance(duration, bool)
    if not ok or not (math.isfinite(duration) and low <= duration <= MAX_DURATION):
        raise ScenarioError(
            f"{where}={duration!r} is out of range: allowed [{low:g}, {MAX_DURATION:g}] s "
            f"(at least {MIN_CONTROL_PERIODS} control periods T_C)"
        )
    return float(duration)


MAX_SEEDS = 10000
"""Most seeds of a study per scenario and combination (--seeds): 10000 corner runs take about 3 h on
two cores; a larger count is a typo far more often than a plan (1e9 jobs fill the memory first)."""


def check_seed_count(seeds, where: str = "--seeds", maximum: int = MAX_SEEDS) -> int:
    """A number of seeds in 1 .. ``maximum``."""
    if isinstance(seeds, bool) or not isinstance(seeds, int) or not 1 <= seeds <= maximum:
        raise ScenarioError(f"{where}={seeds!r} is out of range: allowed 1 .. {maximum}")
    return seeds


def _non_finite(value, where: str):
    """The first key path below ``value`` holding NaN or inf (outside INFINITY_ALLOWED), else None."""
    if dc.is_dataclass(value):
        for field in dc.fields(value):
            found = _non_finite(getattr(value, field.name), f"{where}.{field.name}" if where else field.name)
            if found:
                return found
    elif isinstance(value, dict):
        for key, item in value.items():
            found = _non_finite(item, f"{where}.{key}")
            if found:
                return found
    elif isinstance(value, (list, tuple)):
        for i, item in enumerate(value):
            found = _non_finite(item, f"{where}[{i}]")
            if found:
                return found
    elif isinstance(value, float) and not math.isfinite(value):
        if not (math.isinf(value) and where in INFINITY_ALLOWED):
            return f"{where}={value!r}"
    return None


def check_plausible(scenario: Scenario) -> None:
    """Reject settings that are physically impossible or that the models cannot represent (README:
    Scenario files; systems/checks.py for the robot and follower limits)."""
    found = _non_finite(scenario, "")
    if found:
        raise ScenarioError(f"{found} is not a finite number: allowed finite values")
    name = scenario.name
    if "/" in name or "\\" in name or ".." in name or "\0" in name:
        raise ScenarioError(
            f"name={name!r} is not allowed: artifact file names take no path separators or '..'"
        )
    robot = scenario.robot_parameters()
    _wrap(lambda: check_robot_physics(robot, "robot_overrides."))
    _wrap(lambda: check_follower_gains(scenario.follower, scenario.T_C))
    if scenario.duration is not None:
        check_duration(scenario, scenario.duration, "duration")
    V_m = robot.wheel_speed_limit
    allowed = f"allowed [0, V_m = {V_m:g}] m/s (robot wheel_speed_limit)"
    if scenario.path_speed is not None and scenario.path_speed > V_m:
        raise ScenarioError(f"path_speed={scenario.path_speed!r} is out of range: {allowed}")
    if scenario.trajectory is not None:
        speed = scenario.trajectory.initial_speed
        if speed > V_m:
            raise ScenarioError(f"trajectory.initial_speed={speed!r} is out of range: {allowed}")
        for i, seg in enumerate(scenario.trajectory.segments):
            for key in ("v_end", "v_peak"):
                value = getattr(seg, key, None)
                if value is not None and value > V_m:
                    where = f"trajectory.segments[{i}].{key}"
                    raise ScenarioError(f"{where}={value!r} is out of range: {allowed}")
        _wrap(lambda: check_trajectory_size(scenario.trajectory))
    if scenario.path is not None:
        _wrap(lambda: check_path_size(scenario.path))


def with_keys(scenario: Scenario, changes: dict) -> Scenario:
    """A copy of ``scenario`` with ``{dotted key path: value}`` set (e.g. ``navigation.mixing.b1``,
    ``plant.robot_overrides.mass``, ``trajectory.segments[1].length``), validated as a loaded scenario:
    unknown keys, wrong types and out-of-range values raise ScenarioError naming the key."""
    for key, value in changes.items():
        steps = key_steps(key)
        scenario = replaced_at(scenario, Scenario, steps, value, "")
    return with_paper_mode(scenario.validate())
