"""The baselines every run is judged against, on the raw sensors: odometry-only dead reckoning (S(10),
S(21) with v_n = 0) and Gyrodometry (Indiveri et al. Algorithm 1).

A baseline reads the sensors as they come, before the navigation's checks: an encoder angle that is not
finite is skipped (odometry_step: the next finite difference spans the gap), a gyro reading that is not
finite holds the last finite one (held_reading). The gyro passes the model's sensor correction, which is
the robot's calibration, not a check.
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.navigation.gyrodometry import GyrodometryParameters, gyrodometry_step
from slipnav.systems.navigation.odometry import odometry_step, wheel_radii
from slipnav.systems.navigation.pose import pose_step
from slipnav.systems.navigation.sensor_correction import SensorCalibration, corrected_gyro


def held_reading(value: float, last: float) -> float:
    """A baseline's reading: ``value`` when finite, else the ``last`` finite one."""
    return value if math.isfinite(value) else last


@dc.dataclass
class BaselineState:
    """The baselines' state after each sample (the plain loop's; the block holds the same groups)."""

    odometry: list  # odometry_step's
    odometry_pose: list  # [x, y, phi]
    gyrodometry: list  # gyrodometry_step's [x, y, phi, drift, rate PT1]
    gyro: float  # the last finite (corrected) gyro reading

    @classmethod
    def initial(cls, initial_pose, initial_speed: float) -> "BaselineState":
        """At rest or at ``initial_speed`` (m/s) in ``initial_pose``, no encoder reading yet."""
        v, pose = float(initial_speed), [float(p) for p in initial_pose]
        return cls([np.nan, np.nan, 0.0, v, 0.0, v, v], pose, [*pose, 0.0, 0.0], 0.0)


def baselines_step(
    state: BaselineState,
    encoders,
    gyro: float,
    wheel_radius,
    track_width: float,
    params: GyrodometryParameters,
    T_N: float,
    calibration: SensorCalibration | None = None,
) -> None:
    """One T_N sample of both baselines from the raw ``encoders`` [theta_R, theta_L] (rad) and ``gyro``
    (rad/s), in place: S(10) on the encoder differences, then S(21) of the odometry's pose and
    Algorithm 1 with the held, corrected gyro."""
    state.odometry, odo, _ = odometry_step(state.odometry, encoders, wheel_radius, track_width, T_N)
    reading = gyro if calibration is None else corrected_gyro(calibration, gyro)
    state.gyro = held_reading(reading, state.gyro)
    state.odometry_pose = pose_step(state.odometry_pose, odo[0], 0.0, odo[1], T_N)
    state.gyrodometry = gyrodometry_step(state.gyrodometry, odo[0], odo[1], state.gyro, params, T_N)


class Baselines(LeafSystem):
    """Odometry-only and Gyrodometry on the raw sensors (module docstring), every T_N.

    .. pydrake_system::

        name: Baselines
        input_ports:
        - encoders
        - gyro
        output_ports:
        - odometry_pose
        - gyrodometry_pose

    - encoders: the raw wheel angles [theta_R, theta_L] (rad); gyro: the raw reading [omega] (rad/s).
    - odometry_pose, gyrodometry_pose: [x, y, phi] (m, m, rad; state): the poses at t_k; the update at
      t_k (baselines_step) makes them those of t_k+1.

    Args:
        params: GyrodometryParameters. wheel_radius, track_width: the model's geometry (m; one radius or
            the pair (r_R, r_L)). T_N: period (s). initial_pose, initial_speed: the run's start.
        calibration: the model's SensorCalibration for the gyro (None: none).
    """

    def __init__(
        self,
        params: GyrodometryParameters,
        wheel_radius,
        track_width: float,
        T_N: float,
        initial_pose=(0.0, 0.0, 0.0),
        initial_speed: float = 0.0,
        calibration: SensorCalibration | None = None,
    ):
        super().__init__()
        r_R, r_L = wheel_radii(wheel_radius)
        self._geometry = ((r_R, r_L) if r_R != r_L else r_R, float(track_width))
        self._p, self._T_N = params, T_N
        self._calibration = None if calibration is None or calibration.is_identity() else calibration
        self._encoders = self.DeclareVectorInputPort("encoders", 2)
        self._gyro = self.DeclareVectorInputPort("gyro", 1)
        state = BaselineState.initial(initial_pose, initial_speed)
        self._odometry = self.DeclareDiscreteState(np.array(state.odometry))
        self._odometry_pose = self.DeclareDiscreteState(np.array(state.odometry_pose))
        self._gyro_pose = self.DeclareDiscreteState(np.array(state.gyrodometry[0:3]))
        self._gyro_rest = self.DeclareDiscreteState(np.array([*state.gyrodometry[3:5], state.gyro]))
        self.DeclareStateOutputPort("odometry_pose", self._odometry_pose)
        self.DeclareStateOutputPort("gyrodometry_pose", self._gyro_pose)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _update(self, context, discrete_state):
        drift, rate, gyro = discrete_state.get_value(self._gyro_rest).tolist()
        state = BaselineState(
            discrete_state.get_value(self._odometry).tolist(),
            discrete_state.get_value(self._odometry_pose).tolist(),
            [*discrete_state.get_value(self._gyro_pose).tolist(), drift, rate],
            gyro,
        )
        baselines_step(
            state,
            self._encoders.Eval(context).tolist(),
            self._gyro.Eval(context).tolist()[0],
            *self._geometry,
            self._p,
            self._T_N,
            self._calibration,
        )
        discrete_state.set_value(self._odometry, state.odometry)
        discrete_state.set_value(self._odometry_pose, state.odometry_pose)
        discrete_state.set_value(self._gyro_pose, state.gyrodometry[0:3])
        discrete_state.set_value(self._gyro_rest, [*state.gyrodometry[3:5], state.gyro])
