"""slipnav reproduce (studies/reproduce.py): each figure function on cheap inputs, the helpers by hand, and
the command writing a page that references every figure with the numbers of its runs."""

import contextlib
import io
import json
import math
import re
import shutil

import matplotlib.pyplot as plt
import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.run_plan import follower_path
from slipnav.studies import reproduce as rp
from slipnav.studies import reproduce_measures as measures
from slipnav.studies import reproduce_runs
from slipnav.studies.cli import main
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.weights import logsig

from tests.shared import scenario_result, scenario_run

KEYS = [
    "seyr-fig4",
    "seyr-fig5",
    "seyr-fig6",
    "seyr-fig7",
    "seyr-fig8",
    "indiveri-fig2",
    "indiveri-fig5",
    "indiveri-fig6",
    "indiveri-fig7",
    "indiveri-fig8",
    "indiveri-fig9",
]


@pytest.fixture(autouse=True)
def _close_figures():
    yield
    plt.close("all")


@pytest.fixture(scope="module")
def corner():
    """The default corner run (shared: tests/shared.py)."""
    r, path = scenario_run("corner"), follower_path(load_scenario("corner"))
    return measures.Run(r.arrays, r.summary, r.reference, path, "slipnav run corner")


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """``slipnav reproduce --quick`` once: (its folder, what it printed, the runs it made)."""
    out = tmp_path_factory.mktemp("quick")
    made = {}
    make_runs = rp.make_runs

    def keep(*args, **kwargs):
        made.update(runs := make_runs(*args, **kwargs))
        return runs

    printed = io.StringIO()
    with pytest.MonkeyPatch.context() as m, contextlib.redirect_stdout(printed):
        m.setattr(rp, "make_runs", keep)
        m.setattr(reproduce_runs, "run_scenario", scenario_result)  # corner's runs, shared (tests/shared.py)
        assert main(["reproduce", "--quick", "--out", str(out)]) == 0
    return out / "reproduce", printed.getvalue(), made


@pytest.fixture(scope="module")
def circles(quick):
    """Short circle runs (4 s): bounded, constant, and the lifted variant (to 6 s), those of reproduce
    --quick (the same runs as run_specs(quick=True) names them)."""
    runs = quick[2]
    return {"bounded": runs["circle"], "constant": runs["circle_constant"], "lifted": runs["lifted"]}


def _labels(fig):
    return [(ax.get_xlabel(), ax.get_ylabel()) for ax in fig.axes]


def test_seyr_fig4_is_the_logsig_of_the_modes_mixing():
    m = MixingParameters()
    r = rp.seyr_fig4(m)
    labels = _labels(r.figure)
    assert ("$\\Delta v_K$ S(11) (m/s)", "C1 (1)") in labels
    assert any(y == "C3 (1)" for _, y in labels)
    line = r.figure.axes[0].lines[0]
    x, y = line.get_data()
    assert y[np.argmin(np.abs(x - m.b1))] == pytest.approx(0.5, abs=0.02)  # the threshold: halfway
    assert y[200] == pytest.approx(logsig(m.a1, 0.0, m.b1))  # x = 0: odometric
    assert np.allclose(y, y[::-1])  # double-sided
    assert r.numbers["c1_transition_m_s"] == pytest.approx(2 * math.log(9) / m.a1)
    paper = rp.seyr_fig4(paper_mode(load_scenario("corner")).navigation.mixing, "paper")
    assert paper.numbers["b3"] == 0.05 and r.numbers["b3"] == 0.02  # S(14) per sample in paper mode


def test_indiveri_fig2_without_runs_is_the_wheel_speed_square():
    r = rp.indiveri_fig2(4.1, 0.25)
    for ax in r.figure.axes[0:2]:  # the two plots (their colour bars after them): the paper's points
        labels = {text.get_text(): text.xy for text in ax.texts}
        assert labels == {"A": (4.1, 0.0), "B": (0.0, 4.1), "C": (4.1, 4.1), "D": (0.0, 0.0)}
    assert ("$v_l$ (m/s)", "$v_r$ (m/s)") in _labels(r.figure)
    assert "V_m = 4.1" in r.measured
    assert r.figure.axes[0].get_xlim()[1] == pytest.approx(4.1 * 1.02)


def test_seyr_figures_on_the_corner(corner):
    a = corner.arrays
    five = rp.seyr_fig5(corner)
    assert five.numbers["min_step_size"] == pytest.approx(np.nanmin(a["step_size"][measures.moving_mask(a)]))
    assert five.numbers["max_lag_samples"] > 0  # slip control fell behind the nominal K
    six = rp.seyr_fig6(corner)
    assert [y for _, y in _labels(six.figure)][:4] == [
        "$v_t$ (m/s)",
        "$v_n$ (m/s)",
        "$\\alpha$ (deg)",
        "step size $\\delta_K$ (1)",
    ]
    assert six.numbers["peak_alpha_true_deg"] == pytest.approx(corner.summary["peak_abs_true_alpha_deg"])
    seven = rp.seyr_fig7(corner)
    assert seven.numbers["detections"] == len(measures.detection_onsets(a))
    assert seven.numbers["divergence_s"] == pytest.approx(
        np.sum(measures.divergence_mask(a)) * float(a["T_N"])
    )
    eight = rp.seyr_fig8(corner, corner)
    pct = 100 * corner.summary["final_position_error_m"]["fused"] / corner.summary["path_length_m"]
    assert eight.numbers["corner_fused_pct"] == pytest.approx(pct)
    assert f"{pct:.2f} %" in eight.measured
    assert "2.5 %" in eight.claim
    # beside the paper's final error, the RMS and the maximum along the run, from the summary's metres
    for figure in ("rms", "max"):
        along = 100 * corner.summary[f"{figure}_position_error_m"]["fused"] / corner.summary["path_length_m"]
        assert eight.numbers[f"corner_fused_{figure}_pct"] == pytest.approx(along, rel=1e-12)
        assert f"{'RMS' if figure == 'rms' else 'max'} {along:.2f} %" in eight.measured
    assert eight.numbers["corner_fused_max_time_s"] == corner.summary["max_position_error_time_s"]["fused"]


def test_indiveri_figures_on_short_circles(circles):
    b, c, lifted = circles["bounded"], circles["constant"], circles["lifted"]
    two = rp.indiveri_fig2(float(b.arrays["V_m"]), 0.5 * float(b.arrays["track_width"]), (("circle", b),))
    peak = two.numbers["circle"]["peak_command"]
    assert peak <= float(b.arrays["V_m"]) + 1e-9 and peak > 0.5 * float(b.arrays["V_m"])
    five = rp.indiveri_fig5(lifted)
    assert five.numbers["held_wheel"] < 0.05  # the hand holds it
    assert five.numbers["other_during_hold"] < five.numbers["other_before_hold"]  # the other slows
    assert np.allclose(lifted.arrays["true_x"], 0.0) and np.allclose(
        lifted.arrays["true_y"], 0.0
    )  # in the air
    six = rp.indiveri_fig6({"odometry": b, "gyrodometry": b, "fused": b})
    assert six.numbers["fused"]["path_error_rms_m"] == b.summary["path_error_rms_m"]
    seven = rp.indiveri_fig7(b, c)
    assert seven.numbers["rms_constant"] == c.summary["path_error_rms_m"]
    eight = rp.indiveri_fig8(b, c)
    assert eight.numbers["time_ratio"] == pytest.approx(
        measures.following_time(b) / measures.following_time(c)
    )
    assert eight.numbers["one_constant"] == 0.0  # u = V_m/2 on a circle: no wheel near V_m
    assert eight.numbers["one_bounded"] > 0.0
    assert "wheel speed command (m/s)" in [y for _, y in _labels(eight.figure)]


def _fake(t, **series):
    a = {"t": t, "T_N": np.array(t[1] - t[0]), "T_C": np.array(0.02), "start_time": np.array(0.0)}
    a.update(series)
    return measures.Run(a, {"controller_completion_time_s": None}, None, None, "cmd")


def test_helpers_by_hand():
    t = np.arange(0.0, 1.0, 0.01)
    c1 = np.where((t > 0.2) & (t < 0.3) | (t > 0.6) & (t < 0.65), 0.4, 1.0)
    run = _fake(t, C1=c1, est_v_t=np.where(t > 0.5, 0.1, 0.0), true_v_t=np.zeros_like(t))
    assert measures.detection_onsets(run.arrays) == pytest.approx([0.21, 0.61])
    assert measures.divergence_mask(run.arrays).sum() == 49
    V = 4.0
    cmd_R = np.where(t < 0.5, 4.0, 2.0)
    cmd_L = np.where(t < 0.25, 4.0, 1.0)
    run = _fake(t, cmd_R=cmd_R, cmd_L=cmd_L, V_m=np.array(V))
    one, both = measures.saturation_fractions(run)
    assert (one, both) == (pytest.approx(0.5), pytest.approx(0.25))
    assert measures.speed_switches(run) == 1
    assert measures.following_time(run) == pytest.approx(0.99)


def test_reproduce_writes_a_page_referencing_every_figure(quick):
    """--quick: default mode only, the long runs cut short. The page shows every figure's PNG beside its
    caption, claim, measurement and command; the numbers are those of the runs (the corner's: the same
    run made anew)."""
    out, printed, _ = quick
    page = (out / "index.html").read_text()
    record = json.loads((out / "reproduce.json").read_text())
    assert sorted(record["figures"]["default"]) == sorted(KEYS)
    for key in KEYS:
        entry = record["figures"]["default"][key]
        assert (out / entry["png"]).stat().st_size > 10_000
        assert f"src='{key}-default.png'" in page and f"id='{key}'" in page
        assert entry["command"].startswith("slipnav")
    # Seyr Fig. 3: the navigation's block diagram, its signals named (an SVG with graphviz, else the text)
    diagram = out / ("navigation.svg" if shutil.which("dot") else "navigation.dot")
    assert "id='seyr_fig3'" in page and f"'{diagram.name}'" in page
    assert "every T_C = 20 ms" in diagram.read_text() and "Sensor checks" in diagram.read_text()
    # The claims: position error, slip control, speed law, saturation; the page carries the numbers.
    claims = record["claims"]
    assert [c["figure"] for c in claims] == ["seyr-fig8", "seyr-fig6", "indiveri-fig9", "indiveri-fig8"]
    corner = scenario_run("corner")
    pct = 100 * corner.summary["final_position_error_m"]["fused"] / corner.summary["path_length_m"]
    assert record["figures"]["default"]["seyr-fig8"]["numbers"]["corner_fused_pct"] == pytest.approx(pct)
    assert f"fused {pct:.2f} % corner" in claims[0]["measured"]["default"]
    # the claim stated against the final error, the RMS and the maximum along the run
    length = corner.summary["path_length_m"]
    for figure, label in (("rms", "RMS along the run"), ("max", "max along the run")):
        along = 100 * corner.summary[f"{figure}_position_error_m"]["fused"] / length
        assert f"{label}: fused {along:.2f} % corner" in claims[0]["measured"]["default"]
    assert "final (the paper's figure): fused" in claims[0]["measured"]["default"]
    assert "final/RMS/max" in claims[1]["measured"]["default"]
    assert claims[0]["measured"]["default"] in page.replace("&#x27;", "'")
    assert "2.5 %" in page and "50 %" in page
    ratio = record["figures"]["default"]["indiveri-fig9"]["numbers"]["time_ratio"]
    assert re.search(rf"\({100 * ratio:.0f} % of the time\)", claims[2]["measured"]["default"])
    # The lifted circle's scenario file is written and loads: its command can be run.
    lifted = load_scenario(str(out / "lifted_circle.yaml"))
    assert [e.kind for e in lifted.faults] == ["wheel_lifted", "wheel_lifted", "wheel_held", "wheel_pushed"]
    assert "reproduce figures=11" in printed
    # Seyr's corner and square and Indiveri's long path as animations, linked from the page.
    assert record["animations"] == {
        "default": {n: f"{n}-default.html" for n in ("corner", "square", "long_path")}
    }
    for name, file in record["animations"]["default"].items():
        assert f"<a href='{file}'>default</a>" in page
        assert "id='slipnav-legend'" in (out / file).read_text(), name


def test_reproduce_into_a_file_is_a_user_error(tmp_path, capsys):
    target = tmp_path / "a_file"
    target.write_text("")
    assert main(["reproduce", "--quick", "--out", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error:") and "--out" in err
    assert not (tmp_path / "a_file" / "reproduce").exists()
