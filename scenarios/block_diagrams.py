"""Block diagrams of the navigation, control and closed-loop Diagrams, from Drake's GetGraphvizString:
``slipnav diagram NAME [--out FILE.dot|.svg|.png] [--scenario SCENARIO]``."""

import shutil
import subprocess
from pathlib import Path as FilePath

from slipnav.diagrams.closed_loop import ControlSettings, build_closed_loop_diagram, build_control_diagram
from slipnav.diagrams.navigation import build_navigation_diagram
from slipnav.diagrams.records import Belief, Truth
from slipnav.scenarios.config import ScenarioError, load_scenario
from slipnav.scenarios.diagram_labels import readable_dot
from slipnav.scenarios.run_plan import follower_path, reference_for
from slipnav.systems.navigation.parameters import NavigationBelief

DIAGRAM_NAMES = ("navigation", "control", "closed_loop")
FORMATS = (".dot", ".svg", ".png")


def named_diagram(name: str, scenario_name: str = "corner"):
    """The Diagram called ``name`` built for ``scenario_name`` (its robot, rates, tuning and reference)."""
    if name not in DIAGRAM_NAMES:
        raise ScenarioError(f"diagram {name!r} is unknown: allowed {', '.join(DIAGRAM_NAMES)}")
    scenario = load_scenario(scenario_name)
    rates, robot = scenario.rates(), scenario.robot_parameters()
    if name == "navigation":
        return build_navigation_diagram(
            NavigationBelief(scenario.navigation, robot.wheel_radius, robot.track_width, rates)
        )
    reference, initial_speed = reference_for(scenario)
    control = ControlSettings(
        mode=scenario.mode,
        path=follower_path(scenario),
        trajectory=reference,
        follower=scenario.follower,
        step_size=scenario.slip_control,
        slip_control=scenario.slip_control_enabled,
        speed_law=scenario.speed_law,
    )
    if name == "control":
        return build_control_diagram(control, rates, robot)
    truth = Truth(sensors=scenario.sensor_parameters(), seed=scenario.seed, initial_speed=initial_speed)
    belief = Belief(robot=robot, rates=rates, navigation=scenario.navigation)
    return build_closed_loop_diagram(truth, belief, control, log=False).diagram


def export_diagram(name: str, out, scenario_name: str = "corner") -> FilePath:
    """Write the block diagram to ``out`` (its slices named and its blocks framed by rate:
    diagram_labels.readable_dot): .dot always; .svg/.png through graphviz's ``dot`` program."""
    out = FilePath(out)
    if out.suffix not in FORMATS:
        raise ScenarioError(f"--out {out}: the format {out.suffix or '(none)'} is unknown: allowed {FORMATS}")
    allowed = "allowed a FILE.dot, .svg or .png in a writable folder (created if missing)"
    if out.is_dir():
        raise ScenarioError(f"--out={str(out)!r} is a directory: {allowed}")
    if any(folder.exists() and not folder.is_dir() for folder in out.parents):
        raise ScenarioError(f"--out={str(out)!r} cannot be written: a folder of it is a file: {allowed}")
    program = shutil.which("dot")
    if out.suffix != ".dot" and program is None:
        raise ScenarioError(
            f"writing {out.suffix} needs graphviz's 'dot' program, which is not installed "
            "(Debian: apt-get install graphviz); a .dot file needs nothing"
        )
    diagram = named_diagram(name, scenario_name)
    rates = load_scenario(scenario_name).rates()
    dot_source = readable_dot(diagram, diagram.GetGraphvizString(max_depth=2), rates)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
        if out.suffix == ".dot":
            out.write_text(dot_source)
            return out
        command = [program, f"-T{out.suffix[1:]}", "-o", str(out)]
        subprocess.run(command, input=dot_source, text=True, check=True, capture_output=True)
    except OSError as e:
        raise ScenarioError(f"--out={str(out)!r} cannot be written: {e.strerror or e}: {allowed}") from None
    except subprocess.CalledProcessError as e:
        reason = "graphviz's dot: " + (" ".join(e.stderr.split()) or f"exit status {e.returncode}")
        raise ScenarioError(f"--out={str(out)!r} cannot be written: {reason}: {allowed}") from None
    return out
