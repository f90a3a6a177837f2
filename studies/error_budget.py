"""Error budget of the navigation: ``slipnav error-budget [SCENARIO ...] [--seeds N] [--open-loop]``.

Runs each scenario, then replays its logged sensor samples through the plain navigation loop
(systems.navigation.loop.NavigationLoop, the diagram's own functions) with oracle inputs that remove one
cause of error at a time, and prints for each variant the fused position error's final value, RMS and
maximum along the run (% of path length, metrics.position_errors_in_percent) and the RMS error of the
side-slip angle S(19) where |true alpha| > 1 deg (the figures of ``slipnav accuracy``). The final error
alone flatters a closed path, whose errors in scale largely cancel at the end; the RMS and the maximum
count the errors made along the way.

- ``default``: the replay as is; it equals the diagram's estimate sample for sample (checked).
- ``paper's S(15), S(17)``: no tyre curve (mixing.tyre_peak_acceleration = inf, q2_inertial = 1): v_n
  relaxed towards zero below b2 and integrated above instead of relaxed towards the tyre curve's side
  slip, and the odometric v_t without the creep compensation.
- ``S(17) pulled to the steady-turn slip``: the inertial branch of S(17) relaxes towards the side slip of
  a steady turn at v_t omega (mixing.side_slip_from_accelerations = False) instead of the slip at the
  tyre force the accelerometers measure.
- ``paper's S(15)``: the odometric v_t as it is (mixing.odometry_slip_compensation = False) instead of
  less the tyres' creep of the tyre curve.
- ``paper's S(12)``: C1 from this batch's dv alone (mixing.dv_memory = 0) instead of also from the leaky
  sum of the recent batches' dv.
- ``paper's heading``: the EKF gets the raw gyro (yaw_calibration.enabled = False) and S(14) the single
  sample's yaw-rate residual (mixing.c3_residual_time_constant = 0, a3 = 60, b3 = 0.05, the thresholds
  that suited it) instead of the bias-corrected gyro and the residual's PT1.
- ``C1 oracle``: C1 = 0 exactly while the wheels slip (|mean wheel speed - v_t| > ``slip_speed``),
  1 otherwise, instead of S(11)-(12), which report a slip one batch late, and a slip whose batch speed
  difference stays below b1 (or a stationary one) never.
- ``true v_t``: the mixed v_t of S(15) replaced by the true v_t. v_t enters alpha directly and the v_n
  integration of S(2) through -v_t omega T_N.
- ``C2 = 0 from side-slip onset``: S(17) takes the inertial branch wherever |true alpha| exceeds
  ``onset_deg``, i.e. v_n is not relaxed with q2 (towards the tyre model, or zero) while the side slip
  builds up below b2.
- ``true v_t, C2 = 0 from onset``: the two together.
- ``... and S(19) every T_N``: as the previous, with S(18)-(20) evaluated every sample instead of held
  over T_C (side-slip angle only).

A benchmark for understanding the estimator, not a test of it.
"""

import dataclasses as dc
import math
import sys
import time

import numpy as np
from slipnav.scenarios.config import check_seed_count, load_scenario
from slipnav.scenarios.metrics import (
    POSITION_ERROR_FIGURES,
    moving_alpha,
    position_errors_in_percent,
    side_slip_rms_error,
    tangential_slip_speed,
)
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.engine import session
from slipnav.systems.navigation.loop import NavigationLoop, run_navigation_loop
from slipnav.systems.navigation.parameters import NavigationBelief, NavigationInitialState
from slipnav.systems.navigation.sideslip import side_slip_angle

VARIANTS = (
    "default",
    "paper's S(15), S(17): no tyre curve",
    "S(17) pulled to the steady-turn slip",
    "paper's S(15): odometric v_t with the creep",
    "paper's S(12): C1 from this batch's dv",
    "paper's heading: raw gyro, S(14) per sample",
    "C1 oracle",
    "true v_t",
    "C2 = 0 from side-slip onset",
    "true v_t, C2 = 0 from onset",
    "... and S(19) every T_N",
)

POSITION_FIGURES = tuple(f"{figure}_pct" for figure in POSITION_ERROR_FIGURES)
"""A variant's fused position error in % of path length: ``final_pct``, ``rms_pct``, ``max_pct``."""

FIGURES = (*POSITION_FIGURES, "alpha_deg")
"""A variant's figures: POSITION_FIGURES and ``alpha_deg``, the side-slip RMS error (deg)."""


class OracleNavigationLoop(NavigationLoop):
    """NavigationLoop whose velocity mixer S(15)-(17) gets oracle inputs from the true run.

    Args:
        belief: what the navigation is given (NavigationBelief), as NavigationLoop.
        slipping: (N,) bool, C1 = 0 where True and 1 elsewhere (None: the C1 of S(12)).
        true_v_t: (N,) true tangential speed, replacing the mixed v_t of S(15) (None: S(15) as is).
        side_slip: (N,) bool, samples where C2 is forced to 0 (None: C2 of S(13)).
    """

    def __init__(self, belief: NavigationBelief, slipping=None, true_v_t=None, side_slip=None):
        super().__init__(belief)
        self._slipping, self._true_v_t, self._side_slip = slipping, true_v_t, side_slip

    def velocity_mix(self, odo, inertial, c2, c3, previous, standing):
        if self._side_slip is not None and self._side_slip[self.k]:
            c2 = 0.0
        if self._slipping is not None:
            self.c1 = self.c1_mixed = 0.0 if self._slipping[self.k] else 1.0
        mixed = super().velocity_mix(odo, inertial, c2, c3, previous, standing)
        if self._true_v_t is not None:
            mixed[0] = self._true_v_t[self.k]
        return mixed


def papers_heading(navigation):
    """``navigation`` (NavigationParameters) with the paper's heading: the EKF gets the raw gyro, S(14)
    the single sample's yaw-rate residual with the thresholds that suited it (a3 = 60, b3 = 0.05)."""
    return dc.replace(
        navigation,
        yaw_calibration=dc.replace(navigation.yaw_calibration, enabled=False),
        mixing=dc.replace(navigation.mixing, c3_residual_time_constant=0.0, a3=60.0, b3=0.05),
    )


def replay(a: dict, scenario, navigation=None, **oracles) -> dict:
    """Replay the navigation over the run artifact ``a``'s sensor samples; returns the LOOP_KEYS arrays.

    The initial state is the true speed and pose at t_0, as the runner gives both plant and navigation.
    ``navigation``: NavigationParameters (default: the scenario's). ``oracles``: the keyword arguments of
    OracleNavigationLoop.
    """
    belief = scenario.belief()  # what the run's navigation believes: robot, sensors' data sheet, calibration
    initial = NavigationInitialState(
        speed=float(a["true_v_t"][0]),
        pose=(float(a["true_x"][0]), float(a["true_y"][0]), float(a["true_phi"][0])),
    )
    believed = dc.replace(belief, navigation=navigation or belief.navigation).navigation_belief(initial)
    loop = OracleNavigationLoop(believed, **oracles)
    accelerometers = np.column_stack([a[f"meas_{k}"] for k in ("a_t1", "a_n1", "a_t2", "a_n2")])
    encoders = np.column_stack([a["meas_enc_R"], a["meas_enc_L"]])
    return run_navigation_loop(loop, accelerometers, a["meas_gyro"], encoders)


def alpha_every_sample(out: dict, scenario) -> np.ndarray:
    """S(18)-(20) of every sample's mixed estimate (no hold over T_C)."""
    p = scenario.navigation.sideslip
    samples = zip(out["est_v_t"], out["est_v_n"], out["est_omega"], strict=True)
    return np.array([side_slip_angle(v_t, v_n, omega, p)[1] for v_t, v_n, omega in samples])


def error_budget_of_run(a: dict, scenario, onset_deg: float = 0.1, slip_speed: float = 0.03) -> dict:
    """{variant: {figure: value}} on one run artifact ``a`` of ``scenario``, for each of VARIANTS and
    FIGURES: the fused position error's final value, RMS and maximum along the run in % of path length
    (metrics.position_errors_in_percent) and the side-slip RMS error in deg. ``... and S(19) every T_N``
    changes the side-slip angle only: its position figures are NaN.

    Args:
        onset_deg: |true alpha| (deg) from which the C2 oracle holds C2 at 0 (> 0).
        slip_speed: |mean wheel speed - v_t| (m/s) above which the C1 oracle sets C1 = 0 (> 0).

    Raises:
        RuntimeError: if the plain replay does not reproduce the run's estimate (to 1e-9).
    """
    if not onset_deg > 0.0:
        raise ValueError(f"onset_deg={onset_deg!r} is out of range: allowed (0, inf)")
    if not slip_speed > 0.0:
        raise ValueError(f"slip_speed={slip_speed!r} is out of range: allowed (0, inf) m/s")
    side_slip = np.abs(np.nan_to_num(moving_alpha(a))) > math.radians(onset_deg)
    slipping = np.abs(tangential_slip_speed(a)) > slip_speed

    def figures(out, est_alpha=None):
        b = {**a, **out}
        if est_alpha is not None:
            b["est_alpha"] = est_alpha
        errors = position_errors_in_percent(b, "est")
        return {
            **{f"{figure}_pct": errors[figure] for figure in POSITION_ERROR_FIGURES},
            "alpha_deg": math.degrees(side_slip_rms_error(b)),
        }

    default = replay(a, scenario)
    for key in ("est_x", "est_y", "est_alpha"):
        mismatch = float(np.max(np.abs(default[key] - a[key])))
        if mismatch > 1e-9:
            raise RuntimeError(f"the replay's {key} differs from the run's by {mismatch:.1e}")
    both = replay(a, scenario, true_v_t=a["true_v_t"], side_slip=side_slip)
    nav = scenario.navigation
    paper = dc.replace(nav, mixing=dc.replace(nav.mixing, tyre_peak_acceleration=math.inf, q2_inertial=1.0))
    steady_turn = dc.replace(nav, mixing=dc.replace(nav.mixing, side_slip_from_accelerations=False))
    creeping = dc.replace(nav, mixing=dc.replace(nav.mixing, odometry_slip_compensation=False))
    one_batch = dc.replace(nav, mixing=dc.replace(nav.mixing, dv_memory=0.0))
    raw_gyro = papers_heading(nav)
    return {
        "default": figures(default),
        "paper's S(15), S(17): no tyre curve": figures(replay(a, scenario, navigation=paper)),
        "S(17) pulled to the steady-turn slip": figures(replay(a, scenario, navigation=steady_turn)),
        "paper's S(15): odometric v_t with the creep": figures(replay(a, scenario, navigation=creeping)),
        "paper's S(12): C1 from this batch's dv": figures(replay(a, scenario, navigation=one_batch)),
        "paper's heading: raw gyro, S(14) per sample": figures(replay(a, scenario, navigation=raw_gyro)),
        "C1 oracle": figures(replay(a, scenario, slipping=slipping)),
        "true v_t": figures(replay(a, scenario, true_v_t=a["true_v_t"])),
        "C2 = 0 from side-slip onset": figures(replay(a, scenario, side_slip=side_slip)),
        "true v_t, C2 = 0 from onset": figures(both),
        "... and S(19) every T_N": {
            **dict.fromkeys(POSITION_FIGURES, math.nan),
            "alpha_deg": figures(both, alpha_every_sample(both, scenario))["alpha_deg"],
        },
    }


def _mean_worst(values) -> str:
    values = np.asarray(values, float)
    if not np.isfinite(values).any():
        return f"{'-':>15}"
    return f"{np.nanmean(values):6.2f} ({np.nanmax(values):5.2f})"


def run_seed(job: dict) -> dict:
    """The budget of one run (job: scenario, seed, open_loop) as a row: ``<figure>[<variant>]`` for each
    of FIGURES and VARIANTS."""
    scenario = load_scenario(job["scenario"])
    a = run_scenario(scenario, seed=job["seed"], open_loop=job["open_loop"]).arrays
    budget = error_budget_of_run(a, scenario)
    return {f"{figure}[{v}]": budget[v][figure] for v in VARIANTS for figure in FIGURES}


def error_budget(
    names,
    seeds: int,
    open_loop=None,
    stream=None,
    *,
    workers=None,
    scheduler=None,
    out_dir=None,
    resume=False,
) -> dict:
    """Print (to ``stream``, default stdout) and return, per scenario, the budget of each seed (a list of
    error_budget_of_run's dicts); the printed figures are mean (worst) over seeds. Runs on the sweep
    engine (studies/engine.py: ``workers``, ``scheduler``, results in ``out_dir``/error-budget.csv with
    the columns of run_seed, ``resume``)."""
    stream = stream or sys.stdout
    check_seed_count(seeds)
    results = {}
    with session("error-budget", workers, scheduler, out_dir, resume) as (engine, file):
        for name in names:
            start = time.perf_counter()
            jobs = [{"scenario": name, "seed": seed, "open_loop": open_loop} for seed in range(seeds)]
            rows = engine.map(run_seed, jobs, file, label=name)
            budgets = [{v: {f: r[f"{f}[{v}]"] for f in FIGURES} for v in VARIANTS} for r in rows]
            results[name] = budgets
            titles = ("final error %", "RMS error %", "max error %", "alpha RMS deg")
            lines = [
                f"{name}: {seeds} seeds in {time.perf_counter() - start:.1f} s, mean (worst)",
                f"  {'variant':<44} " + "  ".join(f"{title:>15}" for title in titles),
            ]
            for variant in VARIANTS:
                columns = (_mean_worst([b[variant][figure] for b in budgets]) for figure in FIGURES)
                lines.append(f"  {variant:<44} " + "  ".join(columns))
            print("\n".join(lines), file=stream)
    return results
