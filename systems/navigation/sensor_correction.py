"""The sensors' systematic errors as a calibrated model knows them, removed from every sample.

The sensor model (systems/robot/sensors.py) reads a gyro as (1 + s_g) omega + b_g and each two-axis
accelerometer i as (1 + s_i) R(gamma_i) [t, n] + b_i, with R(gamma) [t, n] = [c t + s n, c n - s t]
(c, s = cos, sin of the misalignment gamma). A model file's ``calibration`` (identified by ``slipnav
calibrate``, studies/calibration.py) states s_g, gamma_i and s_i; SensorCorrection inverts the model's
gains for each sample: omega = gyro / (1 + s_g), [t, n] = R(-gamma_i) reading / (1 + s_i).

The biases are not removed: they change at every power-up (the data sheets' turn-on repeatability, the
simulated sensors draw them anew for every run), so the calibration day's b_g and b_i are a record of
that day, and the navigation learns the gyro's at every run's standstill
(systems/navigation/yaw_calibration.py). Removing a stale bias adds the turn-on repeatability to the bias
error (sqrt(2) times the data sheet's residual in expectation: the day's bias and the run's are
independent draws of the same spread).

Where the navigation sits in Seyr & Jakubek's Fig. 3: between the sensor checks (systems/health/,
which judge the readings in the sensors' own units: their data-sheet range, a stuck value) and every
block that reads the inertial sensors (S(1)-(9) EKF, S(11) slip detector, the yaw calibration,
Gyrodometry). A replaced sample (a faulty channel) is corrected alike: the replacements are predictions
of the reading, good to the calibration's few per cent while the channel is out.
"""

import dataclasses as dc
import math

from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import require_in


@dc.dataclass
class SensorCalibration:
    """The sensors' systematic errors as the model believes them (module docstring). Zero everywhere: the
    sensors are taken as perfect (the nominal model).

    Args:
        gyro_scale_error: relative sensitivity error s_g of the gyro (1).
        gyro_bias: the gyro's bias b_g (rad/s) on the calibration day (a record, not removed).
        accel1_scale_error, accel2_scale_error: relative sensitivity errors s_i of the accelerometers (1).
        accel1_misalignment, accel2_misalignment: angle gamma_i of each accelerometer's axes against the
            body's (rad, about the vertical, counter-clockwise).
        accel_bias: biases of a_t1, a_n1, a_t2, a_n2 as read on the calibration day (m/s^2; a record).
    """

    gyro_scale_error: float = 0.0
    gyro_bias: float = 0.0
    accel1_scale_error: float = 0.0
    accel2_scale_error: float = 0.0
    accel1_misalignment: float = 0.0
    accel2_misalignment: float = 0.0
    accel_bias: list[float] = dc.field(default_factory=lambda: [0.0, 0.0, 0.0, 0.0])

    def is_identity(self) -> bool:
        """No gain to correct (the biases are a record, module docstring)."""
        gains = ("gyro_scale_error", "accel1_scale_error", "accel2_scale_error")
        angles = ("accel1_misalignment", "accel2_misalignment")
        return all(getattr(self, name) == 0.0 for name in gains + angles)

    def validate(self, where: str = "calibration") -> "SensorCalibration":
        """Raise ValueError naming ``<where>.<key>`` and its allowed range."""
        for name in ("gyro_scale_error", "accel1_scale_error", "accel2_scale_error"):
            require_in(f"{where}.{name}", getattr(self, name), "(-0.5, 0.5)")
        for name in ("accel1_misalignment", "accel2_misalignment"):
            require_in(f"{where}.{name}", getattr(self, name), "(-0.5, 0.5) rad")
        require_in(f"{where}.gyro_bias", self.gyro_bias, "(-1, 1) rad/s")
        if len(self.accel_bias) != 4 or not all(math.isfinite(b) and abs(b) < 10.0 for b in self.accel_bias):
            raise ValueError(
                f"{where}.accel_bias={self.accel_bias!r}: allowed four finite numbers in (-10, 10) m/s^2"
            )
        return self


def corrected_gyro(calibration: SensorCalibration, gyro: float) -> float:
    """omega = gyro / (1 + s_g) (the bias is the yaw calibration's, module docstring)."""
    return gyro / (1.0 + calibration.gyro_scale_error)


def corrected_accelerometers(calibration: SensorCalibration, readings) -> list[float]:
    """[t1, n1, t2, n2] in the body's axes: R(-gamma_i) reading / (1 + s_i) per accelerometer."""
    out = []
    for i, (gamma, scale) in enumerate(
        (
            (calibration.accel1_misalignment, calibration.accel1_scale_error),
            (calibration.accel2_misalignment, calibration.accel2_scale_error),
        )
    ):
        t = readings[2 * i] / (1.0 + scale)
        n = readings[2 * i + 1] / (1.0 + scale)
        c, s = math.cos(gamma), math.sin(gamma)
        out += [c * t - s * n, s * t + c * n]
    return out


class SensorCorrection(LeafSystem):
    """Removes the model's sensor gains and misalignments from every sample (module docstring):
    stateless, direct feedthrough.

    .. pydrake_system::

        name: SensorCorrection
        input_ports:
        - accelerometers
        - gyro
        output_ports:
        - accelerometers
        - gyro

    - accelerometers: checked readings [a_t1, a_n1, a_t2, a_n2] (m/s^2, the sensors' axes); out: the
      same in the body's axes (corrected_accelerometers).
    - gyro: checked reading [omega] (rad/s); out: corrected_gyro.

    Args:
        calibration: SensorCalibration (validated here).
    """

    def __init__(self, calibration: SensorCalibration):
        super().__init__()
        self._calibration = calibration.validate()
        self._acc_port = self.DeclareVectorInputPort("accelerometers", 4)
        self._gyro_port = self.DeclareVectorInputPort("gyro", 1)
        self.DeclareVectorOutputPort(
            "accelerometers",
            4,
            lambda c, o: o.SetFromVector(
                corrected_accelerometers(self._calibration, [float(v) for v in self._acc_port.Eval(c)])
            ),
            prerequisites_of_calc={self._acc_port.ticket()},
        )
        self.DeclareVectorOutputPort(
            "gyro",
            1,
            self._calc_gyro,
            prerequisites_of_calc={self._gyro_port.ticket()},
        )

    def _calc_gyro(self, context, output):
        output.SetFromVector([corrected_gyro(self._calibration, float(self._gyro_port.Eval(context)[0]))])

    @property
    def calibration(self) -> SensorCalibration:
        return self._calibration
