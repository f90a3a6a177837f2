"""The sensor checks as a Drake block (SensorHealthMonitor), the flags the navigation reads from their
codes, and a run's report of them."""

import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.health.analog import channel_present
from slipnav.systems.health.check import health_check, health_constants
from slipnav.systems.health.layout import (
    STATE_SIZE,
    gyro_bias_step,
    health_initial_state,
    travel_restored,
    yaw_pair_witness,
    yaw_verdict,
)
from slipnav.systems.health.parameters import (
    HEALTH_CLASSES,
    NO_CURRENTS,
    NO_VELOCITY,
    NO_YAW_CALIBRATION,
    NUM_CHANNELS,
    HealthGeometry,
    SensorHealthParameters,
)


def health_report(t, arrays: dict, channels) -> dict:
    """Per flagged channel of a run: the first flagged time (s), the flagged samples, and the samples of
    each class; ``arrays[f"health_{channel}"]`` hold the codes."""
    report = {}
    for channel in channels:
        codes = np.asarray(arrays[f"health_{channel}"])
        flagged = np.flatnonzero(codes > 0)
        if len(flagged) == 0:
            continue
        report[channel] = {
            "first_s": float(t[flagged[0]]),
            "samples": int(len(flagged)),
            "classes": {
                name: int(np.sum(codes == k + 1))
                for k, name in enumerate(HEALTH_CLASSES)
                if np.any(codes == k + 1)
            },
        }
    return report


HEALTH_STEP_LAYOUT = (
    ("state", STATE_SIZE),
    ("accelerometers", 4),
    ("gyro", 1),
    ("encoders", 2),
    ("health", NUM_CHANNELS),
    ("inertial_fault", 1),
    ("encoder_fault", 1),
    ("sensor_fault", 1),
    ("gyro_bias_step", 1),
    ("yaw_pair_witness", 1),
    ("yaw_verdict", 1),
)
"""The SensorHealthMonitor's ``step`` output, in order: (name, size); diagrams/split.py slices it."""


def slip_detector_blind(codes, unusable: bool = False, accelerometer_sets: int = 2) -> bool:
    """S(11) cannot use the sample: both encoders excluded, one encoder excluded while the gyro is (its
    replacement is then its last increment, not the other wheel's and the gyro's), an encoder output that
    cannot serve (``unusable``: odometry_unusable), or no tangential accelerometer of the robot's
    ``accelerometer_sets`` (0, 1 or 2) in. One excluded encoder otherwise advances by the healthy wheel and
    the gyro, whose slip S(11) is there to see; one excluded tangential axis reads its partner's (the
    replacement, isolated by the force reference), which S(11) uses; a gyro or lateral fault alone does
    not touch S(11)."""
    right, left = codes[5] > 0, codes[6] > 0
    if unusable or (right and left) or ((right or left) and codes[4] > 0):
        return True
    for c in (0, 2):  # the tangential channels
        if codes[c] == 0 and channel_present(c, accelerometer_sets):
            return False
    return True


def odometry_unusable(state, sample) -> bool:
    """This sample's encoder output cannot serve S(11): it restores a stuck encoder's missed travel
    (travel_restored), or an angle is not finite (the checks off, or no reading yet) and the odometry holds
    its last speed over it."""
    return travel_restored(state) or not (math.isfinite(sample[5]) and math.isfinite(sample[6]))


def health_flags(codes, unusable: bool = False, accelerometer_sets: int = 2) -> list:
    """[inertial_fault, encoder_fault, sensor_fault]: 1.0 when any accelerometer/gyro, any encoder is
    excluded (codes > 0), when S(11) cannot use the sample (slip_detector_blind); the yaw calibration does
    not learn from a sample with either fault. A robot without accelerometers (``accelerometer_sets`` 0)
    has an inertial_fault on every sample: its inertial estimate carries no kinematics of its own, so the
    tyre-model check rests and the yaw calibration does not learn from wheels whose slip nothing sees."""
    inertial = 1.0 if max(codes[0:5]) > 0 or accelerometer_sets == 0 else 0.0
    encoder = 1.0 if max(codes[5:7]) > 0 else 0.0
    return [inertial, encoder, 1.0 if slip_detector_blind(codes, unusable, accelerometer_sets) else 0.0]


class SensorHealthMonitor(LeafSystem):
    """Checks every sensor channel, excludes and replaces the faulty ones (systems/health/check.py).

    .. pydrake_system::

        name: SensorHealthMonitor
        input_ports:
        - accelerometers
        - gyro
        - encoders
        - motor_currents
        - body_velocity
        - tyre_peak
        - yaw_calibration
        output_ports:
        - step

    - inputs: the samples as read; optional (health_step's arguments): motor_currents (unconnected: the
      odometry's force reference), body_velocity (the EKF's state; unconnected: the odometric v_t and no
      v_n), tyre_peak (the velocity mixer's state; unconnected: the nominal), yaw_calibration (the
      YawRateCalibration's state; unconnected: 0, 0).
    - step (direct feedthrough), in HEALTH_STEP_LAYOUT's order: the next state; the accepted or replaced
      samples; health, the code of each channel (0 healthy, k: HEALTH_CLASSES[k - 1]); the flags
      (health_flags); gyro_bias_step, the step of b_g measured on an excluded gyro this sample (rad/s, 0:
      none), and yaw_pair_witness, 1 when the accelerometer pair witnessed the yaw rate on this sample
      (layout.yaw_pair_witness), and yaw_verdict, the yaw test's verdict on the gyro (layout.yaw_verdict:
      1 confirmed, -1 blamed, 0 not judged), for the calibration. One vector, so that one Python call per
      sample computes them all; the navigation diagram slices it with a Demultiplexer (diagrams/split.py).

    Update every T_N: health_step's state.

    Args:
        params: SensorHealthParameters. geometry: HealthGeometry. initial_speed: wheels' speed before t=0.
    """

    def __init__(self, params: SensorHealthParameters, geometry: HealthGeometry, initial_speed: float = 0.0):
        super().__init__()
        params.__post_init__()
        self._p, self._g = params, geometry
        self._constants = health_constants(params, geometry)
        self._inputs = [
            self.DeclareVectorInputPort(name, size)
            for name, size in (("accelerometers", 4), ("gyro", 1), ("encoders", 2))
        ]
        self._optional = [  # the optional inputs and what an unconnected one reads
            (self.DeclareVectorInputPort(name, size), unconnected)
            for name, size, unconnected in (
                ("motor_currents", 2, NO_CURRENTS),
                ("body_velocity", 2, NO_VELOCITY),
                ("tyre_peak", 1, (math.nan,)),
                ("yaw_calibration", 2, NO_YAW_CALIBRATION),
            )
        ]
        self._state = self.DeclareDiscreteState(health_initial_state(geometry, initial_speed))
        prereq = {self.xd_ticket()} | {port.ticket() for port in self._inputs}
        prereq |= {port.ticket() for port, _ in self._optional}
        size = sum(n for _, n in HEALTH_STEP_LAYOUT)
        self._step = self.DeclareVectorOutputPort("step", size, self._calc, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(geometry.T_N, 0.0, self._update)

    def _calc(self, context, output):
        raw = tuple([v for port in self._inputs for v in port.Eval(context).tolist()])
        state = context.get_discrete_state(self._state).get_value()
        currents, velocity, (peak,), calibration = (
            tuple(port.Eval(context).tolist()) if port.HasValue(context) else unconnected
            for port, unconnected in self._optional
        )
        state, out, codes = health_check(state, raw, currents, self._constants, velocity, peak, calibration)
        step = output.get_mutable_value()  # written in place: no list of the whole vector
        step[0:STATE_SIZE] = state
        flags = health_flags(codes, odometry_unusable(state, out), self._g.accelerometer_sets)
        witness = 1.0 if yaw_pair_witness(state) else 0.0
        step[STATE_SIZE:] = [*out, *codes, *flags, gyro_bias_step(state), witness, yaw_verdict(state)]

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._state, self._step.Eval(context)[0:STATE_SIZE])
