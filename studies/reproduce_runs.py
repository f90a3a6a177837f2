"""The runs ``slipnav reproduce`` makes: the built-in scenarios and the lifted circle (Indiveri Fig. 5),
each in default and paper mode, with the command that makes each."""

from __future__ import annotations

from pathlib import Path as FilePath

from slipnav.scenarios.config import BUILTIN_DIR, load_scenario, scenario_from_yaml
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.run_plan import follower_path
from slipnav.scenarios.runner import run_scenario
from slipnav.studies.reproduce_measures import Run

LIFTED_EVENTS = """faults:
  - {kind: wheel_lifted, channel: wheel_R, start: 0.0, duration: 3600.0}
  - {kind: wheel_lifted, channel: wheel_L, start: 0.0, duration: 3600.0}
  - {kind: wheel_held, channel: wheel_R, start: 2.5, duration: 0.5}
  - {kind: wheel_pushed, channel: wheel_L, start: 5.0, duration: 0.5, value: 5.0}
"""
"""Indiveri Fig. 5: Kurt3D on the circle with both wheels in the air (no ground contact), the right wheel
stopped by hand (1) for 0.5 s, then the left one turned faster (2) with 5 N m for 0.5 s."""


def lifted_circle_yaml() -> str:
    """The circle scenario with LIFTED_EVENTS (Indiveri Fig. 5), as a scenario file."""
    text = (BUILTIN_DIR / "circle.yaml").read_text()
    return "name: lifted_circle\n" + text + LIFTED_EVENTS


def run_specs(quick: bool = False) -> dict:
    """name -> (scenario name or 'lifted_circle', run options, command tail). ``quick``: shorter
    durations of the long runs (the test's reduced set)."""
    short = (lambda s: {"duration": s}) if quick else (lambda s: {})
    dur = (lambda s: f" --duration {s:g}") if quick else (lambda s: "")
    return {
        "corner": ("corner", {}, ""),
        "corner_no_sc": ("corner", {"slip_control": False}, " --no-slip-control"),
        "square": ("square", short(4.0), dur(4.0)),
        "square_no_sc": ("square", {"slip_control": False, **short(4.0)}, " --no-slip-control" + dur(4.0)),
        "circle": ("circle", short(4.0), dur(4.0)),
        "circle_constant": (
            "circle",
            {"speed_law": "constant", **short(4.0)},
            " --speed-law constant" + dur(4.0),
        ),
        "circle_odometry": (
            "circle",
            {"localisation": "odometry", **short(4.0)},
            " --localisation odometry" + dur(4.0),
        ),
        "circle_gyrodometry": (
            "circle",
            {"localisation": "gyrodometry", **short(4.0)},
            " --localisation gyrodometry" + dur(4.0),
        ),
        "lifted": (
            "lifted_circle",
            {"localisation": "odometry", "speed_law": "constant", **short(6.0)},
            " --localisation odometry --speed-law constant" + dur(6.0),
        ),
        "long_path": ("long_path", short(8.0), dur(8.0)),
        "long_path_constant": (
            "long_path",
            {"speed_law": "constant", **short(8.0)},
            " --speed-law constant" + dur(8.0),
        ),
    }


def make_runs(mode: str, quick: bool = False, yaml_dir=None, progress=None) -> dict:
    """Every run of ``run_specs`` in ``mode`` (default or paper), in this process. ``yaml_dir``: where
    lifted_circle.yaml is (its command names it)."""
    lifted_path = FilePath(yaml_dir or ".") / "lifted_circle.yaml"
    runs = {}
    for name, (scenario_name, options, tail) in run_specs(quick).items():
        if scenario_name == "lifted_circle":
            scenario = scenario_from_yaml(lifted_circle_yaml(), "lifted_circle")
            target = str(lifted_path)
        else:
            scenario, target = load_scenario(scenario_name), scenario_name
        if mode == "paper":
            scenario, tail = paper_mode(scenario), tail + " --paper"
        result = run_scenario(scenario, **options)
        runs[name] = Run(
            result.arrays,
            result.summary,
            result.reference,
            follower_path(scenario),
            f"slipnav run {target}{tail}",
        )
        if progress:
            progress(name, mode, result.summary)
    return runs
