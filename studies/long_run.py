"""Long-run benchmark: memory and covariance health over an hour (issue 18).

    python -m slipnav.studies.long_run [SCENARIO] [--duration S] [--spin S] [--out DIR]

1. ``slipnav run SCENARIO --duration S`` (default: square_laps, an hour of square laps with 5 s at rest
   between them, 3600 s) in a child process: its peak resident
   memory (getrusage of the child, as ``/usr/bin/time -v`` reports it), wall time, and the summary's
   ``completed``, ``aborted``, the extreme eigenvalues and asymmetry of the EKF covariance P (checked
   every 0.1 s of simulated time by navigation_health.NavigationHealth) and each estimate's final, RMS
   and maximum position error along the run (position_error_lines).
2. ``--spin S`` (default 3600 s; 0 skips): S seconds of spinning on the spot at 20 rad/s through the plain
   navigation loop (systems.navigation.loop.NavigationLoop, the diagram's functions) on synthetic sensors,
   P checked every 0.1 s: without the mixing in P (systems/navigation/ekf.py) its velocity block reaches 1e300
   in ~860 s and the estimate NaN.
"""

import argparse
import json
import math
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from slipnav.systems.navigation.loop import NavigationLoop
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.parameters import NavigationBelief, NavigationParameters
from slipnav.systems.rates import SampleRates

SPIN_RATE = 20.0
"""rad/s: Tinyphoon spinning on the spot at its wheel-speed limit (0.068 m/s per rad/s)."""


def run_child(scenario: str, duration: float, out: Path) -> dict:
    """``slipnav run`` in a child process; returns its summary with ``peak_rss_MB``, ``exit_status`` and
    ``total_wall_s`` (simulation, collection and writing)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    command = [sys.executable, "-m", "slipnav.studies.cli", "run", scenario, "--duration", str(duration)]
    start = time.perf_counter()
    done = subprocess.run([*command, "--out", str(out)], capture_output=True, text=True)
    wall = time.perf_counter() - start
    peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss  # kB on Linux, the largest child's
    summaries = sorted(out.glob("*.summary.json"), key=lambda p: p.stat().st_mtime)
    summary = json.loads(summaries[-1].read_text()) if summaries else {}
    summary.update(
        peak_rss_MB=max(peak, before) / 1024.0,
        exit_status=done.returncode,
        total_wall_s=wall,
        stderr=done.stderr.strip(),
    )
    return summary


def spin(duration: float, T_N: float = 0.002, T_C: float = 0.02, seed: int = 0) -> dict:
    """Spinning on the spot at SPIN_RATE for ``duration`` s through NavigationLoop (Tinyphoon: r = 15 mm,
    track 68 mm, 6144 counts): the extreme eigenvalues of P (every 0.1 s), the largest velocity
    variance, and whether the estimate stayed finite."""
    rng = np.random.default_rng(seed)
    params = NavigationParameters(mixing=MixingParameters(odometry_slip_compensation=False))
    loop = NavigationLoop(NavigationBelief(params, 0.015, 0.068, SampleRates(T_N, T_C)))
    step = 2.0 * math.pi / 6144
    wheel_rate = 0.034 * SPIN_RATE / 0.015  # rad/s of each wheel
    low, high, velocity, asymmetry, finite = math.inf, 0.0, 0.0, 0.0, True
    start = time.perf_counter()
    for k in range(int(duration / T_N)):
        theta = wheel_rate * (k + 1) * T_N
        noise = rng.standard_normal(5)
        row = loop.step(
            0.06 * noise[0:4],
            SPIN_RATE + 0.014 * noise[4],
            [math.floor(theta / step) * step, math.floor(-theta / step) * step],
        )
        P = loop.P
        if k % 50 == 0 or k == int(duration / T_N) - 1:
            finite = finite and bool(np.all(np.isfinite(row)) and np.all(np.isfinite(P)))
            if not finite:
                break
            eigenvalues = np.linalg.eigvalsh(P)
            low, high = min(low, eigenvalues[0]), max(high, eigenvalues[-1])
            velocity = max(velocity, P[0, 0], P[1, 1])
            asymmetry = max(asymmetry, float(np.max(np.abs(P - P.T))))
    return {
        "duration_s": duration,
        "finite": finite,
        "min_eigenvalue": low,
        "max_eigenvalue": high,
        "max_velocity_variance": velocity,
        "max_asymmetry": asymmetry,
        "wall_s": time.perf_counter() - start,
    }


def position_error_lines(summary: dict) -> list[str]:
    """One line per estimate of a run's summary: its final, RMS and maximum position error along the run
    (m; the summary's final_position_error_m, rms_position_error_m, max_position_error_m) and when the
    maximum occurred (s); "-" where the summary has none."""

    def shown(value, digits=4):
        return "-" if value is None else f"{value:.{digits}f}"

    lines = []
    for label in ("fused", "odometry", "gyrodometry"):
        final, rms, largest, when = (
            summary.get(key, {}).get(label)
            for key in (
                "final_position_error_m",
                "rms_position_error_m",
                "max_position_error_m",
                "max_position_error_time_s",
            )
        )
        lines.append(
            f"  position error {label:<12} final {shown(final)} m, RMS {shown(rms)} m, max "
            f"{shown(largest)} m at {shown(when, 1)} s"
        )
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m slipnav.studies.long_run", description=__doc__.split("\n")[0]
    )
    parser.add_argument("scenario", nargs="?", default="square_laps")
    parser.add_argument("--duration", type=float, default=3600.0, help="simulated time of the run (s)")
    parser.add_argument("--spin", type=float, default=3600.0, help="simulated time of the spin (s); 0 skips")
    parser.add_argument("--out", default="runs/long_run", help="directory of the run's artifact")
    args = parser.parse_args(argv)
    if not 0.0 <= args.spin <= 36000.0:
        parser.exit(2, f"slipnav: error: --spin={args.spin!r} is out of range: allowed [0, 36000] s\n")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    s = run_child(args.scenario, args.duration, out)
    print(
        f"{args.scenario} {args.duration:g} s closed loop: exit status {s['exit_status']}, peak RSS "
        f"{s['peak_rss_MB']:.0f} MB, wall {s['total_wall_s']:.0f} s "
        f"(simulation {s.get('wall_time_s', math.nan):.0f} s)"
    )
    if s.get("duration_s") is not None:
        print(
            f"  completed {s['completed']}, aborted {s['aborted']}, simulated {s['duration_s']:.1f} s; "
            f"P over the run: eigenvalues {s['covariance_min_eigenvalue']:.3g} .. "
            f"{s['covariance_max_eigenvalue']:.3g}, asymmetry {s['covariance_max_asymmetry']:.3g}"
        )
        for line in position_error_lines(s):
            print(line)
    if s["stderr"]:
        print(f"  stderr: {s['stderr']}")
    if args.spin > 0.0:
        r = spin(args.spin)
        print(
            f"spin {r['duration_s']:g} s at {SPIN_RATE:g} rad/s (plain loop, {r['wall_s']:.0f} s): finite "
            f"{r['finite']}, P eigenvalues {r['min_eigenvalue']:.3g} .. {r['max_eigenvalue']:.3g}, largest "
            f"velocity variance {r['max_velocity_variance']:.3g} m^2/s^2, asymmetry {r['max_asymmetry']:.3g}"
        )
    return 0 if s["exit_status"] == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
