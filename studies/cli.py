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
    slipnav replay LOG.csv [--model MODEL.yaml] [--out DIR] [--no-figures] [--engine plain|diagram]
    slipnav import phil-turtlebot|norlab-warthog DIR [--out DIR] [--model MODEL.yaml]
                   [--resample interpolate|hold]
    slipnav evaluate LOG.csv|RUN.npz --truth TRUTH.csv [--model MODEL.yaml] [--out DIR]
                     [--engine plain|diagram]
    slipnav calibrate SESSION.yaml [--out DIR]
    slipnav calibrate LOG.csv --truth TRUTH.csv [--model MODEL] [--out DIR]
    slipnav calibrate --simulate ROBOT|SCENARIO.yaml [--seed N | --seeds N] [--logs] [--out DIR]
    slipnav reproduce [--out DIR] [--quick]
    slipnav results [--only SECTION ...] [--seeds N] [--workers N] [--out docs/results.md] [--datasets DIR]

ENGINE (studies/sweep.py): [--workers N] [--scheduler ADDRESS] [--out DIR] [--resume]: the runs go to a
dask.distributed cluster of N worker processes (default one per core; 0: in this process) or to the
cluster at ADDRESS, and each finished run is appended to DIR/<study>.csv, which --resume continues.
``--engine`` of replay and evaluate is what steps the navigation over a sensor log
(scenarios/replay_engines.py): the plain loop (default) or the navigation diagram, the same arrays.

User mistakes print one line to stderr (``slipnav: error: ...`` naming the key and the allowed range) and
exit with status 2, without a traceback, before any simulation starts. Ctrl-C prints ``slipnav:
interrupted`` and exits with status 130, leaving no half-written artifact.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path as FilePath

from slipnav.scenarios import import_rosbag, import_turtlebot, import_warthog
from slipnav.scenarios.animation import animate_file, write_run_animation
from slipnav.scenarios.artifacts import check_output_directory
from slipnav.scenarios.block_diagrams import export_diagram
from slipnav.scenarios.config import (
    ScenarioError,
    builtin_scenarios,
    check_duration,
    check_seed_count,
    load_scenario,
)
from slipnav.scenarios.evaluate import evaluate_command
from slipnav.scenarios.importers import LogImportError, write_import
from slipnav.scenarios.model import ModelError
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.replay import replay_file, sensor_columns_without_samples, write_replay_artifacts
from slipnav.scenarios.replay_engines import REPLAY_ENGINES
from slipnav.scenarios.run_plan import RunOptions, check_run_options
from slipnav.scenarios.runner import run_scenario, write_artifacts
from slipnav.scenarios.sensor_log import SensorLogError
from slipnav.studies.accuracy import accuracy
from slipnav.studies.bench import bench
from slipnav.studies.calibration_commands import calibrate_command, calibrate_session_command
from slipnav.studies.cli_parser import build_parser
from slipnav.studies.engine import check_engine_options
from slipnav.studies.error_budget import error_budget
from slipnav.studies.faults import faults, select_cases
from slipnav.studies.random_faults import random_faults
from slipnav.studies.reproduce import reproduce
from slipnav.studies.results_page import write_results
from slipnav.studies.results_sections import SECTIONS
from slipnav.studies.robustness import robustness, robustness_calibrated
from slipnav.studies.sweep import parse_set_options, sweep
from slipnav.studies.truth_calibration import calibrate_truth_command
from slipnav.systems.checks import require_seed
from slipnav.systems.robot.parameters import ROBOTS

USER_MISTAKES = (ScenarioError, ModelError, SensorLogError)
"""A scenario, a model file or a sensor log that cannot be used: each message names the key and the
allowed range; the command line prints it as one line and exits with status 2."""

MAX_CALIBRATION_SEEDS = 1000
"""Most seeds of ``slipnav calibrate --simulate --seeds`` (about 15 s each)."""

MAX_RANDOM_FAULTS = 10000
"""Most seeds of ``slipnav faults --random N`` (one random fault each)."""

ADAPTERS = {"phil-turtlebot": import_turtlebot, "norlab-warthog": import_warthog, "ros-bag": import_rosbag}
"""``slipnav import``'s adapters: each module's ``import_trial`` reads one recording into an ImportResult,
its ``summary`` is the line of estimates."""


def _engine(args) -> dict:
    """The sweep engine's options (studies/sweep.py), checked before any run."""
    check_engine_options(args.workers, args.scheduler)
    check_output_directory(args.out)
    return dict(workers=args.workers, scheduler=args.scheduler, out_dir=args.out, resume=args.resume)


def _check_study(args, duration=None) -> None:
    """A study's --seeds and scenarios (and --duration against each), before any run starts."""
    check_seed_count(args.seeds)
    for name in args.scenarios:
        scenario = load_scenario(name)
        if duration is not None:
            check_duration(scenario, duration)


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


def _position_error_text(s: dict, label: str) -> str:
    """An estimate's final, RMS and maximum position error of a summary, e.g. "final 0.0086 m, RMS 0.0363
    m, max 0.0594 m at 5.63 s along the run" (the final one may be null: the last row's truth missing)."""
    final = s["final_position_error_m"][label]
    return (
        f"final {'-' if final is None else f'{final:.4f}'} m, RMS {s['rms_position_error_m'][label]:.4f} m, "
        f"max {s['max_position_error_m'][label]:.4f} m at {s['max_position_error_time_s'][label]:.2f} s "
        "along the run"
    )


def _list(args) -> int:
    """slipnav list: the built-in scenarios, one per line."""
    for name in builtin_scenarios():
        print(name)
    return 0


def _run(args) -> int:
    """slipnav run: simulate, write the artifact (and the animation), report; 3 if the run stopped early."""
    scenario = load_scenario(args.scenario)
    if args.paper:
        scenario = paper_mode(scenario)
    if args.model is not None:
        scenario = dataclasses.replace(scenario, model=args.model).validate()
    options = RunOptions(
        seed=args.seed,
        duration=args.duration,
        slip_control=False if args.no_slip_control else None,
        speed_law=args.speed_law,
        open_loop=args.open_loop or None,
        tolerances=args.tolerances,
        localisation=args.localisation,
    )
    check_run_options(scenario, options)  # every mistake before the simulation starts
    check_output_directory(args.out)
    result = run_scenario(scenario, options)
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
    if s["rms_position_error_m"]["fused"] is not None:
        print(f"  fused position error {_position_error_text(s, 'fused')}")
    if s["aborted"]:  # the artifact is written, up to the stop; the run itself failed
        print(f"slipnav: error: {s['scenario']} stopped early: {s['aborted']}", file=sys.stderr)
        return 3
    if not s["moved"]:
        print(
            f"slipnav: warning: {s['scenario']} did not move: the robot travelled {s['travelled_m']:.3g} m "
            f"of its {s['path_length_m']:.3f} m path (moved: false): no path error figures",
            file=sys.stderr,
        )
    if not s["completed"]:
        print(
            f"slipnav: warning: {s['scenario']} did not complete: the robot never came within "
            f"{s['completion_tolerance_m']:.3f} m of the end of its path; it stopped "
            f"{s['end_distance_m']:.3f} m from the end, "
            f"{s['path_length_m'] - s['end_progress_m']:.3f} m short along the path (completed: false)",
            file=sys.stderr,
        )
    return 0


def _animate(args) -> int:
    """slipnav animate: a run's npz as one HTML animation (scenarios/animation.py); prints the file."""
    print(animate_file(args.run, args.out, args.fps))
    return 0


def _diagram(args) -> int:
    """slipnav diagram: a block diagram as graphviz (scenarios/block_diagrams.py); prints the file."""
    print(export_diagram(args.name, args.out or f"{args.name}.dot", args.scenario))
    return 0


def _bench(args) -> int:
    """slipnav bench: the closed-loop diagram against the plain loop (studies/bench.py)."""
    bench(args.scenario, args.repeat)
    return 0


def _accuracy(args) -> int:
    """slipnav accuracy: navigation accuracy over seeds (studies/accuracy.py)."""
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


def _error_budget(args) -> int:
    """slipnav error-budget: navigation errors with oracle inputs (studies/error_budget.py)."""
    _check_study(args)
    error_budget(args.scenarios, args.seeds, open_loop=args.open_loop or None, **_engine(args))
    return 0


def _robustness(args) -> int:
    """slipnav robustness [--calibrated]: toleranced robots against the baselines (studies/robustness.py)."""
    _check_study(args)
    engine = _engine(args)
    study = robustness_calibrated if args.calibrated else robustness
    study(args.scenarios, args.seeds, engine.pop("workers"), engine.pop("out_dir"), **engine)
    return 0


def _faults(args) -> int:
    """slipnav faults over the fixed list of cases (studies/faults.py); with --random N, _random_faults."""
    if args.random is not None:
        return _random_faults(args)
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


def _random_faults(args) -> int:
    """``slipnav faults --random N`` (studies/random_faults.py); the fixed list's options are mistakes."""
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


def _sweep(args) -> int:
    """slipnav sweep: a scenario over seeds and --set values (studies/sweep.py)."""
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


def _reproduce(args) -> int:
    """slipnav reproduce: the papers' figures on one page (studies/reproduce.py)."""
    check_output_directory(args.out)
    reproduce(args.out, quick=args.quick, modes=("default",) if args.quick else ("default", "paper"))
    return 0


def _results(args) -> int:
    """slipnav results: measure the page of figures, docs/results.md (studies/results_page.py); prints it;
    1 if a section failed (its old text kept)."""
    path, failed = write_results(SECTIONS, args.only, args.seeds, args.workers, args.out, args.datasets)
    print(path)
    return 1 if failed else 0


def _replay(args) -> int:
    """slipnav replay: the navigation alone on a sensor log (scenarios/replay.py); 1 if --out cannot take
    the artifacts."""
    check_output_directory(args.out)
    engine = args.engine or REPLAY_ENGINES[0]
    result = replay_file(args.log, args.model, engine)  # every log or model mistake before the replay
    if not _write(write_replay_artifacts, result, args):
        return 1
    s = result.summary
    errors = s["final_position_error_m"]
    if not s["has_truth"]:
        truth = " (no truth columns: no error figures)"
    elif errors["fused"] is None or errors["odometry"] is None:
        truth = " (the last row's truth is missing: no final error)"
    else:
        truth = f"; final position error fused {errors['fused']:.4f} m, odometry {errors['odometry']:.4f} m"
    print(f"{s['scenario']}: {s['rows']} rows replayed with model {s['model']}{truth}")
    if s["rms_position_error_m"]["fused"] is not None:
        print(f"  fused position error {_position_error_text(s, 'fused')}")
    empty = sensor_columns_without_samples(result.arrays)
    if empty:
        print(
            f"slipnav: warning: sensor log {args.log!r}: the columns {', '.join(empty)} hold no valid sample "
            "(every cell nan or empty): the estimates rest on no sample of them",
            file=sys.stderr,
        )
    return 0


def _import(args) -> int:
    """slipnav import: a real robot's logs as sensor log, ground truth and model (scenarios/importers.py);
    prints the files and one line of estimates."""
    if args.adapter not in ADAPTERS:
        raise LogImportError(f"ADAPTER={args.adapter!r} is unknown: allowed {', '.join(ADAPTERS)}")
    check_output_directory(args.out)
    adapter = ADAPTERS[args.adapter]
    result = adapter.import_trial(args.trial, args.model, args.resample)
    for path in write_import(result, args.out):
        print(path)
    print(adapter.summary(result.report))
    return 0


def _evaluate(args) -> int:
    """slipnav evaluate: the estimates against a ground truth (scenarios/evaluate.py)."""
    evaluate_command(args.log, args.truth, args.out, args.model, args.engine)
    return 0


def _calibrate(args) -> int:
    """slipnav calibrate: a session file, or a simulated session of a built-in robot or of a scenario's
    plant (studies/)."""
    if args.truth is not None or args.model is not None:
        return _calibrate_against_truth(args)
    if (args.session is None) == (args.simulate is None):
        raise ScenarioError("give a calibration session SESSION.yaml or --simulate ROBOT (one of them)")
    if args.session is not None:
        flags = (("--seed", args.seed), ("--seeds", args.seeds))
        given = [flag for flag, value in flags if value is not None]
        given += ["--logs"] if args.logs else []
        if given:
            raise ScenarioError(
                f"{', '.join(given)} with a calibration session: allowed with --simulate only (a session's "
                "logs are recorded, not drawn)"
            )
        check_output_directory(args.out)
        calibrate_session_command(args.session, args.out)
        return 0
    scenario = None
    if args.simulate not in ROBOTS:
        if FilePath(args.simulate).suffix not in (".yaml", ".yml") and not FilePath(args.simulate).is_file():
            raise ScenarioError(
                f"--simulate={args.simulate!r} is unknown: allowed {', '.join(sorted(ROBOTS))} or a scenario "
                "YAML file (its plant is the truth)"
            )
        scenario = load_scenario(args.simulate)
    if args.seeds is not None and args.seed is not None:
        raise ScenarioError(
            f"--seed={args.seed} with --seeds={args.seeds}: allowed one of them (--seeds N calibrates seeds "
            "0 .. N-1)"
        )
    if args.seeds is not None:
        check_seed_count(args.seeds, maximum=MAX_CALIBRATION_SEEDS)
    seed = 0 if args.seed is None else args.seed
    try:
        require_seed(seed, "--seed")
    except ValueError as e:
        raise ScenarioError(str(e)) from None
    check_output_directory(args.out)
    seeds = list(range(args.seeds)) if args.seeds is not None else [seed]
    robot = args.simulate if scenario is None else scenario.robot
    calibrate_command(robot, seeds, args.out, logs=args.logs, scenario=scenario)
    return 0


def _calibrate_against_truth(args) -> int:
    """slipnav calibrate LOG --truth TRUTH: a real robot's log fitted to its ground truth (studies/)."""
    if args.truth is None or args.session is None:
        raise ScenarioError("--model applies with a sensor log LOG.csv and --truth TRUTH.csv: allowed both")
    flags = (("--simulate", args.simulate), ("--seed", args.seed), ("--seeds", args.seeds))
    given = [flag for flag, value in flags if value is not None] + (["--logs"] if args.logs else [])
    if given:
        raise ScenarioError(
            f"{', '.join(given)} with --truth: allowed LOG.csv, --truth, --model and --out only"
        )
    calibrate_truth_command(args.session, args.truth, args.model, args.out)
    return 0


COMMANDS = {
    "list": _list,
    "run": _run,
    "animate": _animate,
    "diagram": _diagram,
    "bench": _bench,
    "accuracy": _accuracy,
    "error-budget": _error_budget,
    "robustness": _robustness,
    "faults": _faults,
    "sweep": _sweep,
    "reproduce": _reproduce,
    "results": _results,
    "replay": _replay,
    "import": _import,
    "evaluate": _evaluate,
    "calibrate": _calibrate,
}
"""Each subcommand's handler (studies/cli_parser.py defines its options): the parsed arguments in, the
exit status out."""


def main(argv=None) -> int:
    """Parse ``argv`` (default: sys.argv) and run the command's handler; its exit status."""
    try:
        args = build_parser(__doc__.splitlines()[0]).parse_args(argv)
        return COMMANDS[args.command](args)
    except USER_MISTAKES as e:
        print(f"slipnav: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("slipnav: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
