"""The robustness study (studies/robustness.py): each case changes only the plant, the table's figures
are the runs' own, and the last line carries the worst figures."""

import io

import pytest
from slipnav.scenarios.cli import main
from slipnav.studies import robustness as study


def test_cases_change_the_plant_only_and_the_last_line_summarises(monkeypatch, tmp_path):
    cases = {"matched": study.CASES["matched"], "right radius +1 %": study.CASES["right radius +1 %"]}
    monkeypatch.setattr(study, "CASES", cases)
    stream = io.StringIO()
    rows = study.robustness(["corner"], 1, workers=0, out_dir=tmp_path, stream=stream)
    matched, right = rows
    # the right wheel's +1 % wrecks plain odometry's heading (0.23 rad/s at 1.6 m/s), not the fusion's
    assert right["odometry_pct"] > 3 * matched["odometry_pct"]  # measured 14.5 % against 3.1 %
    assert right["fused_pct"] < min(right["odometry_pct"], right["gyrodometry_pct"])
    assert matched["fused_pct"] < 0.5
    last = stream.getvalue().strip().splitlines()[-1]
    worst = max(matched["fused_pct"], right["fused_pct"])
    ratio = max(
        r["fused_pct"] / min(r["odometry_pct"], r["gyrodometry_pct"]) for r in rows
    )  # one seed: mean ratio = the seed's ratio
    assert last.startswith("robustness worst_fused_pct=")
    values = dict(item.split("=") for item in last.split()[1:])
    assert float(values["worst_fused_pct"]) == pytest.approx(worst, abs=1e-3)
    assert float(values["worst_fused_over_best_baseline"]) == pytest.approx(ratio, abs=1e-3)
    assert (tmp_path / "robustness.png").stat().st_size > 10_000


def test_robustness_command_rejects_bad_options(capsys):
    assert main(["robustness", "corner", "--seeds", "0"]) == 2
    assert "--seeds=0" in capsys.readouterr().err
    assert main(["robustness", "nowhere"]) == 2
    assert "nowhere" in capsys.readouterr().err
