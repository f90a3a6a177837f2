"""Block diagrams from Drake's GetGraphvizString (slipnav diagram)."""

import re
import shutil

import pytest
from slipnav.scenarios.block_diagrams import export_diagram
from slipnav.scenarios.config import ScenarioError, load_scenario
from slipnav.studies.cli import main

PAPER_NAMES = {
    "navigation": [
        "EKF",
        "Kalman gain",
        "Odometry",
        "Tangential slip detector",
        "Mixer C1",
        "Mixer C2 C3",
        "Velocity mixer",
        "Side-slip angle",
        "Pose integration",
        "Baselines",
    ],
    "control": [
        "Lyapunov path follower",
        "Wheel-speed saturator",
        "Step-size controller",
        "Trajectory interpolator",
    ],
    "closed_loop": ["Robot plant", "Sensors", "navigation", "control"],
}


@pytest.mark.parametrize("name", sorted(PAPER_NAMES))
def test_dot_export_names_blocks_and_ports(name, tmp_path):
    out = export_diagram(name, tmp_path / f"{name}.dot")
    text = out.read_text()
    assert text.startswith("digraph")
    for block in PAPER_NAMES[name]:
        assert f"name={block}" in text, block
    if name == "navigation":
        for port in ("mixed_estimate", "kalman_gain", "delta_v", "side_slip_angle"):
            assert port in text


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz's dot is not installed")
def test_svg_export(tmp_path, capsys):
    assert main(["diagram", "closed_loop", "--out", str(tmp_path / "loop.svg")]) == 0
    svg = (tmp_path / "loop.svg").read_text()
    assert "<svg" in svg and "Lyapunov path follower" in svg


def test_missing_dot_and_bad_names(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(shutil, "which", lambda program: None)
    with pytest.raises(ScenarioError, match="needs graphviz's 'dot' program"):
        export_diagram("control", tmp_path / "c.png")
    assert main(["diagram", "control", "--out", str(tmp_path / "c.svg")]) == 2
    assert "apt-get install graphviz" in capsys.readouterr().err
    assert main(["diagram", "plant"]) == 2
    assert main(["diagram", "control", "--out", str(tmp_path / "c.pdf")]) == 2
    assert "format .pdf is unknown" in capsys.readouterr().err


def test_the_navigation_diagram_names_its_signals_and_frames_its_rates(tmp_path):
    """No slice of a block's output reads y0, y1, ...: each is named after the input it feeds (the sensor
    checks' health codes feed the exported output 'health', their flags the calibration's inputs), or
    '(not read)'; the blocks with a periodic update sit in one dashed frame per period, the EKF and the
    sensor checks every T_N = 2 ms, the Kalman gain, C1 and the side-slip angle every T_C = 20 ms."""
    from slipnav.scenarios.block_diagrams import named_diagram
    from slipnav.scenarios.diagram_labels import UNREAD, drawn_blocks, rate_groups, signal_names

    diagram = named_diagram("navigation")
    raw = diagram.GetGraphvizString(max_depth=2)
    assert re.search(r">y\d+</TD>", raw)  # Drake's own text
    text = export_diagram("navigation", tmp_path / "navigation.dot").read_text()
    assert not re.search(r">y\d+</TD>", text)
    names = set(signal_names(raw).values())
    assert {"health", "inertial_fault", "encoder_fault", "sensor_fault", "C2_C3"} <= names
    assert UNREAD in text
    nodes = {name: node for node, (_, name, _) in drawn_blocks(raw).items()}
    groups = rate_groups(diagram, raw)
    assert set(groups) == {0.002, 0.02}
    assert {nodes[n] for n in ("EKF", "Sensor checks", "Odometry")} <= set(groups[0.002])
    assert {nodes[n] for n in ("Kalman gain", "Mixer C1", "Side-slip angle")} == set(groups[0.02])
    exported = {node: name for node, (_, name, _) in drawn_blocks(text).items()}  # another build's ids
    raw_names = {node: name for name, node in nodes.items()}
    for label, members in (("every T_N = 2 ms", groups[0.002]), ("every T_C = 20 ms", groups[0.02])):
        frame = re.search(rf'label="{label}"\nstyle=dashed\ncolor=gray40\n([^;]*(?:; [^;]*)*);', text)
        framed = {exported[node] for node in frame.group(1).split("; ")}
        assert framed == {raw_names[node] for node in members}, label



def test_a_frame_is_named_by_the_scenarios_rates(tmp_path):
    """The control diagram's blocks run every T_C alone: their frame reads T_C, not the fastest period's
    name; a period that is neither T_N nor T_C reads in ms."""
    from slipnav.scenarios.diagram_labels import rate_label

    text = export_diagram("control", tmp_path / "control.dot").read_text()
    assert 'label="every T_C = 20 ms"' in text and "every T_N" not in text
    rates = load_scenario("corner").rates()
    assert rate_label(0.0005, rates) == "every 0.5 ms" and rate_label(0.002, rates) == "every T_N = 2 ms"


def test_the_closed_loop_figure_in_the_docs_is_the_current_diagram():
    """docs/images/closed_loop.svg (made by `slipnav diagram closed_loop --out docs/images/closed_loop.svg`)
    draws every block and every named slice of the closed loop as the code builds it today."""
    import html
    from pathlib import Path

    from slipnav.scenarios.block_diagrams import named_diagram
    from slipnav.scenarios.diagram_labels import drawn_blocks, readable_dot

    diagram = named_diagram("closed_loop")
    text = readable_dot(diagram, diagram.GetGraphvizString(max_depth=2), load_scenario("corner").rates())
    figure = html.unescape((Path(__file__).parents[1] / "docs" / "images" / "closed_loop.svg").read_text())
    for kind, name, ports in drawn_blocks(text).values():
        assert f"name={name}" in figure, (kind, name)
        for label in filter(None, ports.values()):
            assert f">{label}<" in figure, (name, label)
