"""The ``slipnav`` command line (see README.md, docs/design.md, docs/artifacts.md, docs/scenario-schema.md).

    slipnav list
    slipnav run SCENARIO [--out DIR] [--seed N] [--duration S] [--no-slip-control]
                         [--speed-law bounded|constant] [--open-loop] [--tolerances]
                         [--localisation fused|odometry|gyrodometry|truth] [--paper]
                         [--model MODEL.yaml] [--animate]
    slipnav animate RUN.npz [--out RUN.html] [--fps F]
    slipnav accuracy [SCENARIO ...] [--seeds N] [--open-loop] [--paper] [ENGINE]
    slipnav error-budget [SCENARIO ...] [--seeds N] [--open-loop] [ENGINE]
    slipnav robustness [SCENARIO ...] [--seeds N] [--calibrated] [ENGINE]
    slipnav faults [SCENARIO ...] [--seeds N] [--perturbations] [--open-loop] [--tolerances] [--channels C,..]
                   [--kinds K,..] [ENGINE]
    slipnav faults [SCENARIO ...] --random N [--open-loop] [--tolerances] [ENGINE]
    slipnav sweep SCENARIO [--seeds N] [--set KEY=V1,V2 ...] [--duration S] [--open-loop] [ENGINE]
    slipnav diagram navigation|control|closed_loop [--out FILE.dot|.svg|.png] [--scenario SCENARIO]
    slipnav bench [SCENARIO] [--repeat N]
    slipnav replay LOG.csv [--model MODEL.yaml] [--out DIR] [--no-figures]
    slipnav import phil-turtlebot|norlab-warthog DIR [--out DIR] [--model MODEL.yaml]
                   [--resample interpolate|hold]
    slipnav evaluate LOG.csv|RUN.npz --truth TRUTH.csv [--model MODEL.yaml] [--out DIR]
    slipnav calibrate SESSION.yaml [--out DIR]
    slipnav calibrate --simulate ROBOT [--seed N | --seeds N] [--logs] [--out DIR]
    slipnav reproduce [--out DIR] [--quick]

ENGINE (studies/sweep.py): [--workers N] [--scheduler ADDRESS] [--out DIR] [--resume]: the runs go to a
dask.distributed cluster of N worker processes (default one per core; 0: in this process) or to the
cluster at ADDRESS, and each finished run is appended to DIR/<study>.csv, which --resume continues.

User mistakes print one line to stderr (``slipnav: error: ...`` naming the key and the allowed range) and
exit with status 2, without a traceback, before any simulation starts. Ctrl-C prints ``slipnav:
interrupted`` and exits with status 130, leaving no half-written artifact.
"""

from __future__ import annotations

import argparse
import sys

from slipnav.scenarios.config import ScenarioError, builtin_scenarios, check_duration, load_scenario

EPILOG = (
    "Documentation in the repository: README.md (start here), docs/design.md, docs/artifacts.md (npz and "
    "summary keys, file names), docs/scenario-schema.md (every YAML key)."
)


class _Parser(argparse.ArgumentParser):
    def error(self, message):
        """One line on stderr and exit status 2 (argparse's usage block left out)."""
        self.exit(2, f"slipnav: error: {message} (see slipnav {self.prog.split()[-1]} --help)\n")


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


def _parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="slipnav", description=__doc__.splitlines()[0], epilog=EPILOG)
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
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
    imp = sub.add_parser("import", help="a real robot's logs as a sensor log, ground truth and model")
    imp.add_argument(
        "adapter",
        help="the logs' kind: phil-turtlebot (TurtleBot 2, navX, Vicon), norlab-warthog (Warthog, RTK)",
    )
    imp.add_argument("trial", metavar="TRIAL_DIR", help="the folder of one recording's files")
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
        metavar="ROBOT",
        help="simulated robot (tinyphoon, kurt3d), drawn from the tolerance preset by the seed",
    )
    cal.add_argument(
        "--logs",
        action="store_true",
        help="with --simulate: write each seed's session (DIR/ROBOT-seedN.calibration/) and identify from it",
    )
    cal.add_argument("--seed", type=int, default=0, help="tolerance draw and noise seed (default 0)")
    cal.add_argument("--seeds", type=int, default=None, help="benchmark: seeds 0 .. N-1 instead of --seed")
    cal.add_argument("--out", default="runs", help="directory of the model YAML files (default: runs)")
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
    ben = sub.add_parser("bench", help="speed of the closed-loop diagram vs the plain loop (benchmark)")
    ben.add_argument("scenario", nargs="?", default="corner", help="closed-loop scenario (default corner)")
    ben.add_argument("--repeat", type=int, default=3, help="best of N runs (default 3)")
    return parser


def main(argv=None) -> int:
    try:
        args = _parser().parse_args(argv)
        return _command(args)
    except ScenarioError as e:
        print(f"slipnav: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("slipnav: interrupted", file=sys.stderr)
        return 130


def _engine(args) -> dict:
    """The sweep engine's options (studies/sweep.py), checked before any run."""
    from slipnav.scenarios.runner import check_output_directory
    from slipnav.studies.sweep import check_engine_options

    check_engine_options(args.workers, args.scheduler)
    check_output_directory(args.out)
    return dict(workers=args.workers, scheduler=args.scheduler, out_dir=args.out, resume=args.resume)


def _command(args) -> int:
    if args.command == "list":
        for name in builtin_scenarios():
            print(name)
        return 0
    if args.command == "diagram":
        from slipnav.scenarios.block_diagrams import export_diagram

        print(export_diagram(args.name, args.out or f"{args.name}.dot", args.scenario))
        return 0
    if args.command == "bench":
        from slipnav.studies.bench import bench

        bench(args.scenario, args.repeat)
        return 0
    if args.command == "error-budget":
        from slipnav.studies.error_budget import error_budget

        _check_study(args)
        error_budget(args.scenarios, args.seeds, open_loop=args.open_loop or None, **_engine(args))
        return 0
    if args.command == "robustness":
        from slipnav.studies.robustness import robustness

        _check_study(args)
        engine = _engine(args)
        if args.calibrated:
            from slipnav.studies.robustness import robustness_calibrated

            robustness_calibrated(
                args.scenarios, args.seeds, engine.pop("workers"), engine.pop("out_dir"), **engine
            )
        else:
            robustness(args.scenarios, args.seeds, engine.pop("workers"), engine.pop("out_dir"), **engine)
        return 0
    if args.command == "sweep":
        from slipnav.studies.sweep import parse_set_options, sweep

        sets = parse_set_options(args.set)
        sweep(
            args.scenario,
            args.seeds,
            sets,
            duration=args.duration,
            open_loop=args.open_loop or None,
            **_engine(args),
        )
        return 0
    if args.command == "calibrate":
        from slipnav.scenarios.runner import check_output_directory
        from slipnav.studies.calibration import calibrate_command
        from slipnav.systems.checks import require_seed
        from slipnav.systems.plant import ROBOTS

        if (args.session is None) == (args.simulate is None):
            raise ScenarioError("give a calibration session SESSION.yaml or --simulate ROBOT (one of them)")
        if args.session is not None:
            from slipnav.studies.calibration_session import calibrate_session_command

            check_output_directory(args.out)
            calibrate_session_command(args.session, args.out)
            return 0
        if args.simulate not in ROBOTS:
            raise ScenarioError(
                f"--simulate={args.simulate!r} is unknown: allowed {', '.join(sorted(ROBOTS))}"
            )
        if args.seeds is not None and not 1 <= args.seeds <= 1000:
            raise ScenarioError(f"--seeds={args.seeds} is out of range: allowed 1 .. 1000")
        try:
            require_seed(args.seed, "--seed")
        except ValueError as e:
            raise ScenarioError(str(e)) from None
        check_output_directory(args.out)
        seeds = list(range(args.seeds)) if args.seeds is not None else [args.seed]
        calibrate_command(args.simulate, seeds, args.out, logs=args.logs)
        return 0
    if args.command == "replay":
        return _replay(args)
    if args.command == "import":
        from slipnav.scenarios.importers import import_command

        import_command(args.adapter, args.trial, args.out, args.model, args.resample)
        return 0
    if args.command == "evaluate":
        from slipnav.scenarios.evaluate import evaluate_command

        evaluate_command(args.log, args.truth, args.out, args.model)
        return 0
    if args.command == "animate":
        from slipnav.scenarios.animation import animate_file

        print(animate_file(args.run, args.out, args.fps))
        return 0
    if args.command == "reproduce":
        from slipnav.scenarios.runner import check_output_directory
        from slipnav.studies.reproduce import reproduce

        check_output_directory(args.out)
        reproduce(args.out, quick=args.quick, modes=("default",) if args.quick else ("default", "paper"))
        return 0
    if args.command == "faults" and args.random is not None:
        return _random_faults(args)
    if args.command == "faults":
        from slipnav.studies.faults import faults, select_cases

        args.seeds = 1 if args.seeds is None else args.seeds
        _check_study(args)
        channels, kinds = (
            None if v is None else [n.strip() for n in v.split(",") if n.strip()] or [v]
            for v in (args.channels, args.kinds)
        )
        try:
            select_cases([], channels, kinds)
        except ValueError as error:
            raise ScenarioError(str(error)) from None
        faults(
            args.scenarios,
            args.seeds,
            perturbations=args.perturbations,
            open_loop=args.open_loop,
            tolerances=args.tolerances,
            channels=channels,
            kinds=kinds,
            **_engine(args),
        )
        return 0
    if args.command == "accuracy":
        from slipnav.studies.accuracy import accuracy

        _check_study(args, args.duration)
        accuracy(
            args.scenarios,
            args.seeds,
            args.duration,
            open_loop=args.open_loop or None,
            paper=args.paper,
            **_engine(args),
        )
        return 0
    from slipnav.scenarios.animation import write_run_animation
    from slipnav.scenarios.runner import (
        check_output_directory,
        check_run_options,
        run_scenario,
        write_artifacts,
    )

    scenario = load_scenario(args.scenario)
    if args.paper:
        from slipnav.scenarios.paper import paper_mode

        scenario = paper_mode(scenario)
    if args.model is not None:
        import dataclasses

        scenario = dataclasses.replace(scenario, model=args.model).validate()
    options = dict(
        seed=args.seed,
        duration=args.duration,
        slip_control=False if args.no_slip_control else None,
        speed_law=args.speed_law,
        open_loop=args.open_loop or None,
    )
    check_run_options(scenario, **options)
    options["tolerances"] = args.tolerances  # every mistake before the simulation starts
    options["localisation"] = args.localisation
    check_output_directory(args.out)
    result = run_scenario(scenario, **options)
    if not _write(write_artifacts, result, args):
        return 1
    if args.animate and not _write(lambda r, out, figures: [write_run_animation(r, out)], result, args):
        return 1
    s = result.summary
    print(
        f"{s['scenario']}: {s['duration_s']:.2f} s simulated in {s['wall_time_s']:.2f} s "
        f"(real-time factor {s['realtime_factor']:.1f}); peak |alpha| "
        f"{s['peak_abs_true_alpha_deg']:.1f} deg, peak |slip ratio| {s['peak_abs_slip_ratio']:.2f}"
    )
    if s["aborted"]:  # the artifact is written, up to the stop; the run itself failed
        print(f"slipnav: error: {s['scenario']} stopped early: {s['aborted']}", file=sys.stderr)
        return 3
    if not s["completed"]:
        print(
            f"slipnav: warning: {s['scenario']} did not complete: the robot never came within "
            f"{s['completion_tolerance_m']:.3f} m of the end of its path; it stopped "
            f"{s['end_distance_m']:.3f} m from the end, "
            f"{s['path_length_m'] - s['end_progress_m']:.3f} m short along the path (completed: false)",
            file=sys.stderr,
        )
    return 0


def _write(write, result, args) -> bool:
    """``write(result, --out, figures=...)`` and print the files; False (the error printed) when the
    directory cannot take them."""
    try:
        written = write(result, args.out, figures=not args.no_figures)
    except OSError as e:
        print(f"slipnav: error: cannot write the artifacts into --out={args.out!r}: {e}", file=sys.stderr)
        return False
    for path in written:
        print(path)
    return True


MAX_RANDOM_FAULTS = 10000


def _random_faults(args) -> int:
    """``slipnav faults --random N`` (studies/random_faults.py); the fixed list's options are mistakes."""
    from slipnav.studies.random_faults import random_faults

    if not 1 <= args.random <= MAX_RANDOM_FAULTS:
        raise ScenarioError(f"--random={args.random} is out of range: allowed 1 .. {MAX_RANDOM_FAULTS}")
    given = [
        option
        for option, value in (
            ("--seeds", args.seeds),
            ("--perturbations", args.perturbations or None),
            ("--channels", args.channels),
            ("--kinds", args.kinds),
        )
        if value is not None
    ]
    if given:
        raise ScenarioError(
            f"--random with {', '.join(given)}: allowed --open-loop, --tolerances and the engine's options "
            "(--random N draws the seeds' faults: classes and channels all)"
        )
    args.seeds = args.random
    _check_study(args)
    random_faults(
        args.scenarios, args.random, open_loop=args.open_loop, tolerances=args.tolerances, **_engine(args)
    )
    return 0


def _check_study(args, duration=None) -> None:
    """A study's --seeds and scenarios (and --duration against each), before any run starts."""
    if args.seeds < 1:
        raise ScenarioError(f"--seeds={args.seeds} is out of range: allowed 1, 2, ...")
    for name in args.scenarios:
        scenario = load_scenario(name)
        if duration is not None:
            check_duration(scenario, duration)


def _replay(args) -> int:
    from slipnav.scenarios.replay import replay_file, write_replay_artifacts
    from slipnav.scenarios.runner import check_output_directory

    check_output_directory(args.out)
    result = replay_file(args.log, args.model)  # every log or model mistake before the simulation
    if not _write(write_replay_artifacts, result, args):
        return 1
    s = result.summary
    errors = s["final_position_error_m"]
    truth = (
        f"; final position error fused {errors['fused']:.4f} m, odometry {errors['odometry']:.4f} m"
        if s["has_truth"]
        else " (no truth columns: no error figures)"
    )
    print(f"{s['scenario']}: {s['rows']} rows replayed with model {s['model']}{truth}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
