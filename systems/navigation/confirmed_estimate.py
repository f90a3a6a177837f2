"""The yaw calibration's estimate as the witnesses last confirmed it, and the return to it when the yaw
test blames the gyro.

The calibration (systems/navigation/yaw_calibration.py) learns theta = [b_g, D] from the gyro against the
wheels while the robot drives straight. There the yaw rate is the path follower's corrections, and a gyro
that reads s omega with a wrong scale or sign (s = -1) leaves the residual (s - 1) omega, which b_g and
D v_o / b absorb as the batches come; the bias-change test takes it for a bias step. The gyro shows its
fault in the next turn, where the health layer's yaw test judges it against the wheels and breaks the tie
with the accelerometers (systems/health/yaw_witness.py). So the calibration keeps theta and P as they
stood at the end of the last batch that the witnesses confirmed:

- a batch in which the yaw test judged the gyro in a turn with no evidence against it (its CUSUM's sums
  at zero: the health layer's yaw_verdict 1) and no reading was replaced, or
- a rest the standstill detector confirmed on every sample (the gyro's zero, which a scale does not
  touch),

and, when the yaw test blames the gyro (yaw_verdict -1), returns to it: what the calibration learned since
came from readings no third witness confirmed, the blamed gyro's among them. The batches since add the
random walks to P:

    # predict step: P_c plus the random walks over the batches since the confirmation
    # theta = theta_c

and the bias-change test's sums and change points restart. A fault-free run raises no blame and never
returns: its estimate is the one learned batch by batch.
"""

import numpy as np
from slipnav.systems.navigation.bias_change import NUM_THETA
from slipnav.systems.state_layout import layout_size, layout_slices

CONFIRMED_LAYOUT = (
    ("theta", NUM_THETA),
    ("covariance", NUM_THETA * NUM_THETA),
    ("batches", 1),
    ("judged", 1),
)
"""The confirmed estimate, in order (name, size): theta and P (row-major) at the end of the last
confirmed batch, the batches since, and 1 while a sample of the current batch was confirmed by the yaw
test."""
_SLICES = layout_slices(CONFIRMED_LAYOUT)
_THETA, _P, _BATCHES, _JUDGED = (_SLICES[k] for k in ("theta", "covariance", "batches", "judged"))
CONFIRMED_SIZE = layout_size(CONFIRMED_LAYOUT)


def confirmed_initial_state(theta, P) -> np.ndarray:
    """The prior is confirmed: ``theta`` and ``P`` (NUM_THETA x NUM_THETA), no batch since."""
    state = np.zeros(CONFIRMED_SIZE)
    state[_THETA], state[_P] = theta, np.ravel(P)
    return state


def note_verdict(confirmed, verdict: float) -> None:
    """A sample's yaw_verdict (1 confirmed, -1 blamed, 0 not judged): a confirmation marks the current
    batch (``confirmed``: the CONFIRMED_LAYOUT view, in place)."""
    if verdict > 0.0:
        confirmed[_JUDGED] = 1.0


def confirm_batch(confirmed, theta, P, replaced: bool, rest: bool) -> None:
    """A batch's end, after its update to ``theta`` and ``P``: a batch without a ``replaced`` reading
    that the yaw test confirmed, or a confirmed ``rest``, becomes the confirmed estimate; otherwise one
    more batch since."""
    if not replaced and (confirmed[_JUDGED] > 0.0 or rest):
        confirmed[_THETA], confirmed[_P] = theta, np.ravel(P)
        confirmed[_BATCHES] = 0.0
    else:
        confirmed[_BATCHES] += 1.0
    confirmed[_JUDGED] = 0.0


def confirmed_estimate(confirmed, walk) -> tuple:
    """The return on a blame: (theta, P) of the confirmed estimate, P plus ``walk`` (the random walks'
    covariance over one batch) times the batches since (module docstring)."""
    theta = np.array(confirmed[_THETA], dtype=float)
    # predict step: the random walks since the confirmation
    P = np.reshape(confirmed[_P], (NUM_THETA, NUM_THETA)) + np.asarray(walk) * confirmed[_BATCHES]
    return theta, P
