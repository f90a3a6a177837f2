"""Control of Seyr & Jakubek §V and Indiveri, Nüchter & Lingemann §III: what the robot is commanded.

- path_follower.py: the Lyapunov path follower with a virtual target, the speed law and the wheel-speed
  saturation;
- frenet_loop.py: the path-following error dynamics as a scalar-generic Drake system, for linearisation;
- slip_control.py: slip control, step size S(22)-(23), progress S(24) and the trajectory interpolation;
- feedforward.py: the open-loop feed-forward of a pre-planned trajectory's wheel speeds.
"""

from slipnav.systems.control.feedforward import TrajectoryFeedforward
from slipnav.systems.control.path_follower import (
    LyapunovPathFollower,
    PathFollowerParameters,
    WheelSpeedSaturator,
)
from slipnav.systems.control.slip_control import (
    StepSizeController,
    StepSizeParameters,
    TrajectoryInterpolator,
)

__all__ = [
    "LyapunovPathFollower",
    "PathFollowerParameters",
    "StepSizeController",
    "StepSizeParameters",
    "TrajectoryFeedforward",
    "TrajectoryInterpolator",
    "WheelSpeedSaturator",
]
