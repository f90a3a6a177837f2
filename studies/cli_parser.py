"""The ``slipnav`` command line's argument parser (studies/cli.py runs the commands)."""

from __future__ import annotations

import argparse

from slipnav.scenarios.replay_engines import REPLAY_ENGINES

EPILOG = (
    "Documentation in the repository: README.md (start here), docs/design.md, docs/artifacts.md (npz and "
    "summary keys, file names), docs/scenario-schema.md (every YAML key)."
)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        """One line on stderr and exit status 2 (argparse's usage block left out)."""
        self.exit(2, f"slipnav: error: {message} (see {self.prog} --help)\n")


def _engine_options(parser, study: str) -> None:
    """--workers, --scheduler, --out, --resume of a study on the sweep engine (studies/sweep.py)."""
    parser.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local dask worker processes (default: one per core; 0: run in this process)",
    )
    parser.add_argument(
        "--scheduler", default=None, help="address of an existing dask cluster, e.g. tcp://127.0.0.1:8786"
    )
    parser.add_argument(
        "--out", default="runs", help=f"directory of {study}.csv and the figure (default runs)"
    )
    parser.add_argument(
        "--resume", action="store_true", help=f"keep the finished runs in {study}.csv and run only the rest"
    )


def _replay_engine_option(parser) -> None:
    """--engine of a command that replays a sensor log (scenarios/replay_engines.py)."""
    parser.add_argument(
        "--engine",
        choices=REPLAY_ENGINES,
        default=None,
        help="what steps the navigation over the log: plain (default), its functions in a plain loop; "
        "diagram, the navigation diagram in a Drake simulator (the same arrays bit for bit, slower)",
    )


def _add_simulation_commands(sub) -> None:
    """The subcommands list, run, animate, diagram, bench: one scenario at a time."""
    sub.add_parser("list", help="list the built-in scenarios")
    run = sub.add_parser("run", help="simulate a scenario and write its artifact and figures")
    run.add_argument("scenario", help="built-in scenario name or path to a scenario YAML file")
    run.add_argument("--out", default="runs", help="output directory (default: runs)")
    run.add_argument("--seed", type=int, default=None, help="noise seed (default: the scenario's)")
    run.add_argument("--duration", type=float, default=None, help="simulated time limit (s)")
    run.add_argument("--no-figures", action="store_true", help="skip the figures")
    run.add_argument(
        "--animate",
        action="store_true",
        help="also write DIR/<stem>.html: the run as a 3-D animation (slipnav animate)",
    )
    run.add_argument("--no-slip-control", action="store_true", help="keep the step size at 1")
    run.add_argument(
        "--speed-law",
        choices=["bounded", "constant"],
        default=None,
        help="max_speed mode: I(24) (bounded) or u = V_m/2 (constant)",
    )
    run.add_argument("--open-loop", action="store_true", help="feed-forward the trajectory's wheel speeds")
    run.add_argument(
        "--tolerances",
        action="store_true",
        help="draw the simulated robot from the tolerance preset (scenarios/tolerances.py) by the seed",
    )
    run.add_argument(
        "--localisation",
        choices=("fused", "odometry", "gyrodometry", "truth"),
        default=None,
        help="what the path follower localises by (default: the scenario's, fused)",
    )
    run.add_argument(
        "--paper",
        action="store_true",
        help="the papers' equations as printed, every extension off (README: Paper mode)",
    )
    run.add_argument(
        "--model",
        default=None,
        metavar="MODEL.yaml",
        help="what navigation and control believe (README: Model files), e.g. one slipnav calibrate wrote; "
        "the plant stays the scenario's",
    )
    ani = sub.add_parser(
        "animate", help="a run's npz as a 3-D animation (Meshcat) in one self-contained HTML file"
    )
    ani.add_argument("run", metavar="RUN.npz", help="a run's npz, e.g. runs/corner-seed0.npz")
    ani.add_argument("--out", default=None, metavar="FILE.html", help="default: RUN.html beside the npz")
    ani.add_argument(
        "--fps", type=float, default=30.0, help="frames per second of simulated time (default 30; 1 .. 120)"
    )
    dia = sub.add_parser("diagram", help="write a block diagram (graphviz)")
    dia.add_argument("name", help="navigation, control or closed_loop")
    dia.add_argument("--out", default=None, help="FILE.dot (default NAME.dot), FILE.svg or FILE.png")
    dia.add_argument(
        "--scenario", default="corner", help="scenario the diagram is built for (default corner)"
    )
    ben = sub.add_parser("bench", help="speed of the closed-loop diagram vs the plain loop (benchmark)")
    ben.add_argument("scenario", nargs="?", default="corner", help="closed-loop scenario (default corner)")
    ben.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")


def _add_studies_commands(sub) -> None:
    """The subcommands accuracy, error-budget, robustness, faults, sweep, reproduce: benchmarks over
    seeds on the sweep engine."""
    acc = sub.add_parser("accuracy", help="navigation accuracy over seeds (benchmark)")
    acc.add_argument("scenarios", nargs="*", default=["corner", "square"], help="default: corner square")
    acc.add_argument("--seeds", type=int, default=10, help="number of seeds (default 10)")
    acc.add_argument("--duration", type=float, default=None, help="simulated time limit (s)")
    acc.add_argument("--open-loop", action="store_true", help="feed-forward the trajectory's wheel speeds")
    acc.add_argument(
        "--paper", action="store_true", help="the papers' equations as printed (README: Paper mode)"
    )
    _engine_options(acc, "accuracy")
    bud = sub.add_parser("error-budget", help="navigation errors with oracle inputs (benchmark)")
    bud.add_argument("scenarios", nargs="*", default=["corner", "square"], help="default: corner square")
    bud.add_argument("--seeds", type=int, default=3, help="number of seeds (default 3)")
    bud.add_argument("--open-loop", action="store_true", help="feed-forward the trajectory's wheel speeds")
    _engine_options(bud, "error-budget")
    rob = sub.add_parser(
        "robustness", help="nominal navigation on toleranced robots vs baselines (benchmark)"
    )
    rob.add_argument(
        "scenarios",
        nargs="*",
        default=["corner", "square", "long_path"],
        help="default: corner square long_path",
    )
    rob.add_argument("--seeds", type=int, default=10, help="number of seeds (default 10)")
    rob.add_argument(
        "--calibrated",
        action="store_true",
        help="per preset draw: the nominal, the calibrated (slipnav calibrate on that robot) and true model",
    )
    _engine_options(rob, "robustness")
    fau = sub.add_parser(
        "faults",
        help="every sensor fault class on every channel (or --random N drawn): detection, error (benchmark)",
    )
    fau.add_argument("scenarios", nargs="*", default=["corner", "square"], help="default: corner square")
    fau.add_argument("--seeds", type=int, default=None, help="number of seeds (default 1)")
    fau.add_argument(
        "--random",
        type=int,
        default=None,
        metavar="N",
        help="instead of the fixed list: one random fault per seed 0..N-1 and scenario, with fault-free "
        "references (studies/random_faults.py)",
    )
    fau.add_argument(
        "--perturbations", action="store_true", help="also the plant perturbations (wheel lifted, held, ...)"
    )
    fau.add_argument(
        "--open-loop", action="store_true", help="feed-forward the trajectory's wheel speeds (the same path)"
    )
    fau.add_argument(
        "--tolerances",
        action="store_true",
        help="draw the simulated robot from the tolerance preset by the seed (the navigation: nominal)",
    )
    fau.add_argument("--channels", default=None, help="only these channels, comma-separated (default all)")
    fau.add_argument("--kinds", default=None, help="only these fault classes, comma-separated (default all)")
    _engine_options(fau, "faults")
    swe = sub.add_parser(
        "sweep", help="a scenario over seeds and --set values on the sweep engine (benchmark)"
    )
    swe.add_argument("scenario", help="built-in scenario name or path to a scenario YAML file")
    swe.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 per combination (default 10)")
    swe.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=V1,V2",
        help="scenario key (dotted path, e.g. navigation.mixing.b1) and its values; repeat for a product",
    )
    swe.add_argument("--duration", type=float, default=None, help="simulated time limit (s)")
    swe.add_argument("--open-loop", action="store_true", help="feed-forward the trajectory's wheel speeds")
    _engine_options(swe, "sweep-SCENARIO")
    rpr = sub.add_parser(
        "reproduce",
        help="the papers' figures (Seyr 4-8, Indiveri 2, 5-9) recreated, default and paper mode: one page",
    )
    rpr.add_argument("--out", default="runs", help="writes DIR/reproduce/index.html and PNGs (default runs)")
    rpr.add_argument(
        "--quick", action="store_true", help="default mode only, the long runs cut short (a smoke test)"
    )


def _add_results_command(sub) -> None:
    """The subcommand results: the page of measured figures (studies/results_page.py)."""
    res = sub.add_parser(
        "results", help="measure the page of figures, docs/results.md, section by section (benchmark)"
    )
    res.add_argument(
        "--only",
        nargs="+",
        action="extend",
        default=None,
        metavar="SECTION",
        help="measure these sections only and keep the others' text (default: every section but the "
        "on-demand ones; the names: docs/results.md)",
    )
    res.add_argument(
        "--seeds", type=int, default=None, help="seeds 0..N-1 of every section (default: each its own)"
    )
    res.add_argument(
        "--workers",
        type=int,
        default=None,
        help="local dask worker processes of the studies (default: one per core; 0: run in this process)",
    )
    res.add_argument("--out", default="docs/results.md", help="the page (default docs/results.md)")
    res.add_argument(
        "--datasets",
        default=None,
        metavar="DIR",
        help="the recorded datasets (default: shared/datasets beside the repository; docs/robot-logs.md)",
    )


def _add_logs_commands(sub) -> None:
    """The subcommands replay, import, evaluate, calibrate: sensor logs, real robots' recordings and
    calibration sessions."""
    rep = sub.add_parser("replay", help="run the navigation alone on a sensor log (CSV)")
    rep.add_argument("log", help="sensor log CSV (README.md: Sensor log), e.g. runs/corner-seed0.sensors.csv")
    rep.add_argument(
        "--model",
        default=None,
        help="model YAML the navigation believes (default: the log's <name>.model.yaml beside it, else the "
        "nominal robot of its '# robot:' line)",
    )
    rep.add_argument("--out", default="runs", help="output directory (default: runs)")
    rep.add_argument("--no-figures", action="store_true", help="skip the figures")
    _replay_engine_option(rep)
    imp = sub.add_parser("import", help="a real robot's logs as a sensor log, ground truth and model")
    imp.add_argument(
        "adapter",
        help="the logs' kind: phil-turtlebot (TurtleBot 2, navX, Vicon), norlab-warthog (Warthog, RTK), "
        "ros-bag (a ROS 1 or 2 bag's Imu, JointState and ground-truth Odometry topics)",
    )
    imp.add_argument(
        "trial", metavar="TRIAL_DIR", help="the folder of one recording's files (ros-bag: the bag)"
    )
    imp.add_argument("--out", default="runs", help="output directory (default: runs)")
    imp.add_argument(
        "--model", default=None, help="model YAML (default: the adapter's data sheet); its T_N is the grid's"
    )
    imp.add_argument(
        "--resample",
        default="interpolate",
        help="streams onto the T_N grid: interpolate (default) or hold",
    )
    eva = sub.add_parser("evaluate", help="fused, odometry-only and Gyrodometry against a ground truth")
    eva.add_argument("log", metavar="LOG", help="sensor log (.csv, replayed first) or a run or replay npz")
    eva.add_argument("--truth", required=True, help="ground-truth CSV t,x,y,yaw,quality (slipnav import)")
    eva.add_argument("--model", default=None, help="model YAML of a sensor log (default as slipnav replay)")
    eva.add_argument("--out", default="runs", help="output directory (default: runs)")
    _replay_engine_option(eva)
    cal = sub.add_parser("calibrate", help="identify the robot's parameters from calibration manoeuvres")
    cal.add_argument(
        "session",
        nargs="?",
        default=None,
        help="calibration session YAML of a real robot's logs and hand measurements (README: Calibration "
        "sessions); or --simulate",
    )
    cal.add_argument(
        "--simulate",
        default=None,
        metavar="ROBOT|SCENARIO.yaml",
        help="simulated robot (tinyphoon, kurt3d), drawn from the tolerance preset by the seed; or a "
        "scenario YAML file, whose plant (robot, plant: section) is the truth",
    )
    cal.add_argument(
        "--logs",
        action="store_true",
        help="with --simulate: write each seed's session (DIR/ROBOT-seedN.calibration/) and identify from it",
    )
    cal.add_argument("--seed", type=int, default=None, help="tolerance draw and noise seed (default 0)")
    cal.add_argument("--seeds", type=int, default=None, help="benchmark: seeds 0 .. N-1 instead of --seed")
    cal.add_argument(
        "--truth",
        default=None,
        help="with a sensor log LOG.csv in place of SESSION: its ground-truth CSV t,x,y,yaw,quality; fits "
        "the radii, the effective track and the gyro's scale and bias (docs/robot-logs.md)",
    )
    cal.add_argument(
        "--model", default=None, help="with --truth: the log's model YAML (default as slipnav replay)"
    )
    cal.add_argument("--out", default="runs", help="directory of the model YAML files (default: runs)")


def build_parser(description: str) -> argparse.ArgumentParser:
    """The ``slipnav`` argument parser: one subparser per command, each mistake one line and exit 2."""
    parser = _Parser(prog="slipnav", description=description, epilog=EPILOG)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    _add_simulation_commands(sub)
    _add_studies_commands(sub)
    _add_results_command(sub)
    _add_logs_commands(sub)
    return parser
