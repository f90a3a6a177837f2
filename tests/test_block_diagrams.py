"""Block diagrams from Drake's GetGraphvizString (slipnav diagram)."""

import shutil

import pytest
from slipnav.scenarios.block_diagrams import export_diagram
from slipnav.scenarios.config import ScenarioError
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
