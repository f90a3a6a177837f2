"""Error budget of the side-slip angle: ``slipnav alpha-budget [SCENARIO ...] [--seeds N] [--open-loop]``.

Runs each scenario, then replays its logged sensor samples through the plain navigation loop
(systems.navigation.NavigationLoop, the diagram's own functions) with oracle inputs that remove one
cause of error at a time, and prints the RMS error of the side-slip angle S(19) where |true alpha| > 1 deg
(the figure of ``slipnav accuracy``) for each variant:

- ``paper``: the replay as is; it equals the diagram's est_alpha sample for sample (checked).
- ``true v_t``: the mixed v_t of S(15) replaced by the true v_t: no tangential slip reaches v_t while C1
  still trusts odometry (S(11) sees a slip one batch late, a stationary slip never) and no inertial drift
  while it does not. v_t matters through S(19) and through the v_n integration of S(2), -v_t omega T_N.
- ``C2 = 0 from side-slip onset``: S(17) takes the inertial v_n wherever |true alpha| exceeds
  ``onset_deg``, i.e. v_n is not relaxed to zero while the side slip builds up below b2.
- ``both``: the two oracles together.
- ``both, S(19) every T_N``: as ``both``, with S(18)-(20) evaluated every sample instead of held over T_C.

A benchmark for understanding the estimator, not a test of it.
"""

import math
import sys
import time

import numpy as np

from scenarios.accuracy import progress
from scenarios.config import ScenarioError, load_scenario
from scenarios.metrics import moving_alpha, side_slip_rms_error
from scenarios.runner import run_scenario
from systems.navigation import NavigationInitialState, NavigationLoop, run_navigation_loop
from systems.sideslip import side_slip_angle

VARIANTS = (
    "paper",
    "true v_t",
    "C2 = 0 from side-slip onset",
    "both",
    "both, S(19) every T_N",
)


class OracleNavigationLoop(NavigationLoop):
    """NavigationLoop whose velocity mixer S(15)-(17) gets oracle inputs from the true run.

    Args:
        true_v_t: (N,) true tangential speed, replacing the mixed v_t of S(15) (None: S(15) as is).
        side_slip: (N,) bool, samples where C2 is forced to 0 (None: C2 of S(13)).
        other arguments: as NavigationLoop.
    """

    def __init__(self, *args, true_v_t=None, side_slip=None, **kwargs):
        super().__init__(*args, **kwargs)
        self._true_v_t, self._side_slip = true_v_t, side_slip

    def velocity_mix(self, odo, inertial, c2, c3, v_n_prev):
        if self._side_slip is not None and self._side_slip[self.k]:
            c2 = 0.0
        mixed = super().velocity_mix(odo, inertial, c2, c3, v_n_prev)
        if self._true_v_t is not None:
            mixed[0] = self._true_v_t[self.k]
        return mixed


def replay(a: dict, scenario, true_v_t=None, side_slip=None) -> dict:
    """Replay the navigation over the run artifact ``a``'s sensor samples; returns the LOOP_KEYS arrays.

    The initial state is the true speed and pose at t_0, as the runner gives both plant and navigation.
    """
    robot, rates = scenario.robot_parameters(), scenario.rates()
    loop = OracleNavigationLoop(
        scenario.navigation,
        robot.wheel_radius,
        robot.track_width,
        rates.T_N,
        rates.T_C,
        NavigationInitialState(
            speed=float(a["true_v_t"][0]),
            pose=(float(a["true_x"][0]), float(a["true_y"][0]), float(a["true_phi"][0])),
        ),
        true_v_t=true_v_t,
        side_slip=side_slip,
    )
    accelerometers = np.column_stack([a[f"meas_{k}"] for k in ("a_t1", "a_n1", "a_t2", "a_n2")])
    encoders = np.column_stack([a["meas_enc_R"], a["meas_enc_L"]])
    return run_navigation_loop(loop, accelerometers, a["meas_gyro"], encoders)


def alpha_every_sample(out: dict, scenario) -> np.ndarray:
    """S(18)-(20) of every sample's mixed estimate (no hold over T_C)."""
    p = scenario.navigation.sideslip
    samples = zip(out["est_v_t"], out["est_v_n"], out["est_omega"], strict=True)
    return np.array([side_slip_angle(v_t, v_n, omega, p)[1] for v_t, v_n, omega in samples])


def alpha_budget_of_run(a: dict, scenario, onset_deg: float = 0.1) -> dict:
    """Side-slip RMS error (deg) of each VARIANT on one run artifact ``a`` of ``scenario``.

    Raises:
        RuntimeError: if the plain replay does not reproduce the run's est_alpha (to 1e-9 rad).
    """
    if not onset_deg > 0.0:
        raise ValueError(f"onset_deg={onset_deg!r} is out of range: allowed (0, inf)")
    side_slip = np.abs(np.nan_to_num(moving_alpha(a))) > math.radians(onset_deg)

    def rms(est_alpha):
        return math.degrees(side_slip_rms_error({**a, "est_alpha": est_alpha}))

    paper = replay(a, scenario)
    mismatch = float(np.max(np.abs(paper["est_alpha"] - a["est_alpha"])))
    if mismatch > 1e-9:
        raise RuntimeError(f"the replay differs from the run's est_alpha by {mismatch:.1e} rad")
    both = replay(a, scenario, true_v_t=a["true_v_t"], side_slip=side_slip)
    return {
        "paper": rms(paper["est_alpha"]),
        "true v_t": rms(replay(a, scenario, true_v_t=a["true_v_t"])["est_alpha"]),
        "C2 = 0 from side-slip onset": rms(replay(a, scenario, side_slip=side_slip)["est_alpha"]),
        "both": rms(both["est_alpha"]),
        "both, S(19) every T_N": rms(alpha_every_sample(both, scenario)),
    }


def alpha_budget(names, seeds: int, open_loop=None, stream=None) -> dict:
    """Print (to ``stream``, default stdout) and return, per scenario, the mean and worst RMS error (deg)
    of each variant over seeds."""
    stream = stream or sys.stdout
    if not (isinstance(seeds, int) and seeds >= 1):
        raise ScenarioError(f"--seeds={seeds!r} is out of range: allowed 1, 2, ...")
    results = {}
    for name in names:
        scenario = load_scenario(name)
        start, budgets = time.perf_counter(), []
        for seed in range(seeds):
            progress(seed, seeds, name)
            a = run_scenario(scenario, seed=seed, open_loop=open_loop).arrays
            budgets.append(alpha_budget_of_run(a, scenario))
        progress(seeds, seeds, name)
        results[name] = budgets
        lines = [
            f"{name}: side-slip RMS error where |alpha| > 1 deg, {seeds} seeds in "
            f"{time.perf_counter() - start:.1f} s (mean, worst)"
        ]
        for variant in VARIANTS:
            values = np.array([b[variant] for b in budgets])
            if np.isfinite(values).any():
                lines.append(f"  {variant:<30} {np.nanmean(values):5.2f} deg  {np.nanmax(values):5.2f} deg")
            else:
                lines.append(f"  {variant:<30} (no samples with |alpha| > 1 deg)")
        print("\n".join(lines), file=stream)
    return results
