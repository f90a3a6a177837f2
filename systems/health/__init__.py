"""The health layer: every sensor channel judged against the other witnesses before anything learns from
it (check.py: the order within a sample), excluded and replaced while it disagrees, re-admitted only on
evidence that it agrees again.

- parameters.py: thresholds, the nominal robot's figures, the health codes;
- layout.py: the checks' state, part by part;
- analog.py, encoders.py, gyro.py, accelerometer_pair.py, pair_gain.py: the tests of each channel;
- yaw_witness.py: the wheels' witness of the gyro and its yaw test;
- ground_speed.py: the ground beneath each wheel, and the encoder that reads its wheel against it;
- perturbation.py, perturbation_monitor.py: a wheel held, pushed or lifted and a push on the body,
  from the commands, the checked encoders, the estimate and the current sense;
- monitor.py: the Drake block, the flags and the run's report.
"""

from slipnav.systems.health.check import health_check, health_constants, health_step
from slipnav.systems.health.layout import (
    gyro_bias_step,
    health_initial_state,
    travel_restored,
    yaw_pair_witness,
    yaw_verdict,
)
from slipnav.systems.health.monitor import (
    HEALTH_STEP_LAYOUT,
    SensorHealthMonitor,
    health_flags,
    health_report,
    odometry_unusable,
)
from slipnav.systems.health.parameters import (
    FORCE_REFERENCE_FIELDS,
    HEALTH_CLASSES,
    INCONSISTENT,
    JUMP,
    NO_CURRENTS,
    NONFINITE,
    RECOVERING,
    SATURATED,
    STUCK,
    HealthConstants,
    HealthGeometry,
    SensorHealthParameters,
)

__all__ = [
    "FORCE_REFERENCE_FIELDS",
    "HEALTH_CLASSES",
    "HEALTH_STEP_LAYOUT",
    "INCONSISTENT",
    "JUMP",
    "NONFINITE",
    "NO_CURRENTS",
    "RECOVERING",
    "SATURATED",
    "STUCK",
    "HealthConstants",
    "HealthGeometry",
    "SensorHealthMonitor",
    "SensorHealthParameters",
    "gyro_bias_step",
    "health_check",
    "health_constants",
    "health_flags",
    "health_initial_state",
    "health_report",
    "health_step",
    "odometry_unusable",
    "travel_restored",
    "yaw_pair_witness",
    "yaw_verdict",
]
