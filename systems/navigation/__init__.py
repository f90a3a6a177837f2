"""The navigation of Seyr & Jakubek's Fig. 3 and its extensions: what the robot believes of its motion,
from the checked sensors (systems/health/).

- parameters.py: NavigationParameters, the initial state, what the sensor checks know (health_geometry);
- odometry.py: S(10); ekf.py: the inertial EKF S(2)-S(9); slip_detector.py: S(11);
- mixing/: the mixing of odometric and inertial estimates S(12)-S(17) with the tyre model;
- sideslip.py: S(18)-S(20); pose.py: S(21);
- standstill.py: the zero-velocity test and update; yaw_calibration.py: the gyro's bias and the wheels'
  radius difference learned online; sensor_correction.py: a calibrated model's sensor errors removed;
- baselines.py, gyrodometry.py: odometry-only and Gyrodometry dead reckoning on the raw sensors;
- loop.py: the plain sequential loop of the same functions (NavigationLoop), the diagram's test oracle.
"""

from slipnav.systems.navigation.loop import LOOP_KEYS, NavigationLoop, navigation_loop, run_navigation_loop
from slipnav.systems.navigation.parameters import (
    NavigationInitialState,
    NavigationParameters,
    health_geometry,
)

__all__ = [
    "LOOP_KEYS",
    "NavigationInitialState",
    "NavigationLoop",
    "NavigationParameters",
    "health_geometry",
    "navigation_loop",
    "run_navigation_loop",
]
