"""The model YAML: what navigation and control believe about the robot (README.md "Model files").

A model names a nominal robot (``robot``, the data sheet) and changes it by what was measured or
identified: ``robot_overrides`` (RobotParameters fields, e.g. ``rolling_radius_R``, ``track_width``),
``sensor_overrides`` (SensorParameters fields of the nominal sensor set, e.g.
``encoder_counts_per_revolution``), ``calibration`` (the sensors' scale errors and misalignments, which
the navigation removes from every sample, and the calibration day's biases as a record:
systems/navigation/sensor_correction.py), ``navigation`` (tuning of the navigation blocks, e.g. the
EKF's ``R`` from an Allan variance, the tyres' ``mixing.tyre_peak_acceleration``, the drag) and
``standard_errors`` (informative: each identified value's standard error, keyed as in
studies/calibration.py). ``slipnav run`` writes the model its navigation read (``<stem>.model.yaml``);
``slipnav calibrate`` writes an identified one; ``slipnav run --model``, ``slipnav replay --model`` and a
scenario's ``model:`` key read them (scenarios/config.py Scenario.belief).

Never the plant: a model changes only the belief. The simulated robot stays the scenario's ``robot``
with its ``plant:`` section.
"""

import dataclasses as dc
import math
from pathlib import Path as FilePath

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed
from slipnav.scenarios.files import write_text_atomically
from slipnav.scenarios.typed_yaml import ScenarioError, check_schema, load_yaml
from slipnav.systems.checks import check_robot_physics
from slipnav.systems.navigation.parameters import NavigationParameters
from slipnav.systems.navigation.sensor_correction import SensorCalibration
from slipnav.systems.rates import SampleRates
from slipnav.systems.robot.parameters import ROBOTS, RobotParameters, robot_parameters
from slipnav.systems.robot.sensors import SensorParameters, default_sensor_parameters

__all__ = ["ModelError", "RobotModel", "SensorCalibration", "load_model", "model_from_text", "model_text"]


class ModelError(ValueError):
    """A model YAML that cannot be loaded; the message names the key."""


@dc.dataclass
class RobotModel:
    """A model file (see the module docstring).

    Args:
        robot: the nominal robot, ``tinyphoon`` or ``kurt3d``.
        description: free text (how the model was made).
        robot_overrides: RobotParameters fields changed from the nominal (m, kg, ...), e.g.
            ``rolling_radius_R``, ``rolling_radius_L``, ``track_width``.
        sensor_overrides: SensorParameters fields of the nominal sensor set.
        calibration: the sensors' systematic errors (SensorCalibration).
        T_N, T_C: navigation and control periods (s).
        navigation: navigation tuning; keys given here replace a scenario's (the rest keep the
            scenario's values).
        standard_errors: the standard error of each identified value (informative).
    """

    robot: str = "tinyphoon"
    description: str = ""
    robot_overrides: dict[str, float] = dc.field(default_factory=dict)
    sensor_overrides: dict[str, float] = dc.field(default_factory=dict)
    calibration: SensorCalibration = dc.field(default_factory=SensorCalibration)
    T_N: float = 0.002
    T_C: float = 0.02
    navigation: NavigationParameters = dc.field(default_factory=NavigationParameters)
    standard_errors: dict[str, float] = dc.field(default_factory=dict)

    def robot_parameters(self) -> RobotParameters:
        if self.robot not in ROBOTS:
            raise ModelError(f"robot={self.robot!r} is unknown: allowed {sorted(ROBOTS)}")
        return _apply(robot_parameters(self.robot), self.robot_overrides, "robot_overrides")

    def sensor_parameters(self) -> SensorParameters:
        return _apply(default_sensor_parameters(self.robot), self.sensor_overrides, "sensor_overrides")

    def rates(self) -> SampleRates:
        try:
            return SampleRates(T_N=self.T_N, T_C=self.T_C)
        except ValueError as e:
            raise ModelError(str(e)) from None

    def navigation_over(self, base: NavigationParameters) -> NavigationParameters:
        """``base`` (a scenario's tuning) with the navigation keys this model's file gives."""
        text = getattr(self, "_source_text", "")
        if not text:
            return self.navigation
        try:
            return yaml_load_typed(
                schema=NavigationParameters,
                data=text,
                child_name="navigation",
                defaults=dc.replace(base),
            ).validate()
        except (RuntimeError, KeyError):  # no navigation key in the file
            return base

    def validate(self) -> "RobotModel":
        """Every value in range, by the checks a scenario's robot passes (systems/checks.py: the robot's
        physics across its parameters); ModelError naming the key."""
        robot = self.robot_parameters()
        try:
            check_robot_physics(robot, "robot_overrides.")
        except ValueError as e:
            raise ModelError(str(e)) from None
        self.sensor_parameters()
        self.rates()
        try:
            self.calibration.validate()
        except ValueError as e:
            raise ModelError(str(e)) from None
        try:
            self.navigation.validate()
        except ValueError as e:
            raise ModelError(f"navigation.{e}") from None
        for key, value in self.standard_errors.items():
            if not (math.isfinite(value) and value >= 0.0):
                raise ModelError(f"standard_errors.{key}={value!r} is out of range: allowed [0, inf)")
        return self


def _apply(base, overrides: dict, where: str):
    names = {f.name for f in dc.fields(base)} - {"name"}
    for key, value in overrides.items():
        if key not in names:
            raise ModelError(f"{where}.{key} is unknown: allowed {sorted(names)}")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ModelError(f"{where}.{key}={value!r} is out of range: allowed finite numbers")
    changes = {k: (int(v) if isinstance(getattr(base, k), int) else float(v)) for k, v in overrides.items()}
    try:
        return dc.replace(base, **changes)
    except ValueError as e:
        raise ModelError(f"{where}.{e}") from None


def model_from_text(text: str, where: str = "model") -> RobotModel:
    """Parse and validate a model YAML text (strict: unknown keys are errors)."""
    try:
        raw = load_yaml(text)
        if not isinstance(raw, dict):
            raise ModelError(f"{where}: expected a mapping of keys (README.md: Model files), got {raw!r}")
        hints = {f.name for f in dc.fields(RobotModel)}
        for key in raw:
            if key not in hints:
                raise ModelError(f"{where}: {key} is an unknown key: allowed {sorted(hints)}")
        check_schema(RobotModel, raw, "")
    except ScenarioError as e:
        raise ModelError(f"{where}: {e}") from None
    try:
        model = yaml_load_typed(schema=RobotModel, data=text)
    except Exception as e:
        raise ModelError(f"{where}: {e}") from None
    model._source_text = text  # navigation_over overlays exactly the keys the file gives
    try:
        return model.validate()
    except ModelError as e:
        raise ModelError(f"{where}: {e}") from None


def load_model(path) -> RobotModel:
    """Read a model YAML file; ModelError naming the file and the key."""
    path = FilePath(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as e:
        raise ModelError(
            f"model file {str(path)!r} cannot be read: {getattr(e, 'strerror', None) or e}"
        ) from None
    return model_from_text(text, where=f"model file {str(path)!r}")


def model_text(model: RobotModel) -> str:
    """YAML text of ``model`` (floats round-trip exactly), the keys that differ from the defaults."""
    header = "# slipnav model: what navigation and control believe (README.md: Model files)\n"
    # Only what differs from the defaults (robot and periods always): a model's navigation keys lie over
    # a scenario's tuning (navigation_over), so it carries only what was tuned or identified.
    return header + yaml_dump_typed(model, defaults=RobotModel(robot="", T_N=math.nan, T_C=math.nan))


def write_model(model: RobotModel, path) -> FilePath:
    """Write ``model`` to ``path`` atomically (files.write_text_atomically)."""
    return write_text_atomically(path, [model_text(model)])
