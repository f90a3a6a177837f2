"""The sweep engine (studies/engine.py): a 2-worker dask cluster gives exactly the serial results, a
resumed sweep skips the finished runs and prints the same table, bad --set values stop before any run."""

import io

import pytest
from slipnav.studies import engine, results_file
from slipnav.studies import sweep as sweep_study
from slipnav.studies.accuracy import accuracy
from slipnav.studies.cli import main

SETS = {"navigation.mixing.b1": ["0.03", "0.05"]}
"""Two combinations whose figures differ (corner, 1 s: fused 0.18 against 0.22 % of path)."""
SHORT = dict(seeds=2, sets=SETS, duration=1.0)


@pytest.fixture(scope="module")
def scheduler():
    """The address of one local cluster of 2 worker processes, shared by this module's tests."""
    with engine.Engine(workers=2) as cluster:
        yield cluster.client.scheduler.address


def _table(text: str) -> list[str]:
    """The printed lines without the timing line and the last line (wall times differ)."""
    return [line for line in text.splitlines() if " runs in " not in line and not line.startswith("sweep ")]


def test_two_workers_give_exactly_the_serial_results(scheduler, tmp_path):
    serial_out, cluster_out = io.StringIO(), io.StringIO()
    serial = sweep_study.sweep("corner", **SHORT, workers=0, out_dir=tmp_path / "serial", stream=serial_out)
    cluster = sweep_study.sweep(
        "corner", **SHORT, scheduler=scheduler, out_dir=tmp_path / "dask", stream=cluster_out
    )
    assert len(serial) == 4
    assert repr(cluster) == repr(serial)  # every float to the last bit (repr: NaN equals NaN)
    fused = {row["set:navigation.mixing.b1"]: row["fused_pct"] for row in serial if row["seed"] == 0}
    assert fused["0.03"] != fused["0.05"]  # the --set value reaches the runs
    assert cluster_out.getvalue().splitlines()[-1].split()[2] == "workers=2"
    assert _table(cluster_out.getvalue())[:4] == _table(serial_out.getvalue())[:4]  # title, header, 2 rows
    assert sorted((tmp_path / "dask" / "sweep-corner.csv").read_text().splitlines()) == sorted(
        (tmp_path / "serial" / "sweep-corner.csv").read_text().splitlines()
    )
    assert (tmp_path / "dask" / "sweep-corner.png").stat().st_size > 10_000


def test_accuracy_on_two_workers_equals_serial(scheduler):
    serial = accuracy(["corner"], 2, 1.0, stream=io.StringIO(), workers=0)
    cluster = accuracy(["corner"], 2, 1.0, stream=io.StringIO(), scheduler=scheduler)
    assert repr(cluster) == repr(serial)


def test_resumed_sweep_skips_finished_runs_and_prints_the_same_table(tmp_path, capsys):
    argv = ["sweep", "corner", "--seeds", "2", "--set", "navigation.mixing.b1=0.03,0.05", "--duration", "1"]
    argv += ["--workers", "0", "--out", str(tmp_path)]
    assert main(argv) == 0
    full = capsys.readouterr().out
    results = tmp_path / "sweep-corner.csv"
    lines = results.read_text().splitlines(keepends=True)
    assert len(lines) == 5  # header and 4 runs
    # as after a kill while the third run's line was being written
    results.write_text("".join(lines[:3]) + lines[3][:40])
    assert main(argv + ["--resume"]) == 0
    captured = capsys.readouterr()
    resumed = captured.out
    assert "2 finished runs resumed" in resumed
    assert resumed.splitlines()[-1].startswith("sweep runs=2 workers=0 ")  # only the two missing runs ran
    assert "2 finished runs resumed" in captured.err  # the progress lines say so too
    assert _table(resumed) == _table(full)
    assert results.read_text().splitlines(keepends=True) == lines  # serial: the same lines, same order


def test_results_file_keeps_complete_lines_and_values_exactly(tmp_path):
    path = tmp_path / "r.csv"
    rows = [
        {
            "scenario": "corner",
            "seed": 0,
            "x": 0.1 + 0.2,
            "n": 3,
            "ok": True,
            "none": None,
            "bad": float("nan"),
        },
        {"scenario": "corner", "seed": 1, "x": 1e-300, "n": -4, "ok": False, "none": None, "bad": 2.5},
    ]
    file = results_file.ResultsFile(path)
    for row in rows:
        file.append(results_file.job_key({"scenario": row["scenario"], "seed": row["seed"]}), row)
    file.close()
    with open(path, "a") as f:
        f.write("scenario=corner;seed=2,corner,2,0.3")  # partial last line
    resumed = results_file.ResultsFile(path, resume=True)
    assert list(resumed.done) == ["scenario=corner;seed=0", "scenario=corner;seed=1"]
    back = [resumed.row(key, {"scenario": "corner", "seed": i}) for i, key in enumerate(resumed.done)]
    assert repr(back) == repr(rows)
    assert path.read_text().endswith("2.5\n")  # the partial line is cut before appending
    resumed.close()


def test_progress_prints_plain_lines_when_not_a_terminal():
    stream = io.StringIO()
    progress = engine.Progress(total=20, done=4, label="sweep corner", stream=stream)
    for _ in range(16):
        progress.update()
    progress.close()
    lines = stream.getvalue().splitlines()
    assert "\r" not in stream.getvalue()
    assert lines[0].startswith("sweep corner: 4/20 runs (20 %)") and "4 finished runs resumed" in lines[0]
    assert [line.split(":")[1].split()[0] for line in lines[1:]] == [f"{n}/20" for n in range(6, 21, 2)]


@pytest.mark.parametrize(
    "options, message",
    [
        (["--set", "navigation.mixing.bb=1"], "navigation.mixing.bb is an unknown key: allowed ['a1'"),
        (
            ["--set", "navigation.mixing.b1=0.05,-1"],
            "--set navigation.mixing.b1=-1: mixing.b1=-1.0 is out of range",
        ),
        (["--set", "settle_time=0.2,abc"], "--set settle_time=abc: settle_time: expected float, got 'abc'"),
        (
            ["--set", "trajectory.segments[7].length=1"],
            "trajectory.segments[7] is out of range: allowed index 0 .. 2",
        ),
        (["--set", "navigation.mixing.b1"], "--set 'navigation.mixing.b1': allowed KEY=VALUE"),
        (["--set", "follower.k2=1", "--set", "follower.k2=2"], "--set follower.k2 is given twice"),
        (["--set", "follower.k2=1,,2"], "has an empty value"),
        (["--set", "seed=1,2"], "--set seed=...: the sweep runs seeds 0..N-1 of --seeds N"),
        (["--seeds", "0"], "--seeds=0 is out of range: allowed 1 .. 10000"),
        (["--duration", "0.01"], "--duration=0.01 is out of range"),
        (["--workers", "-1"], "--workers=-1 is out of range: allowed 0 (in this process) .. 64"),
        (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "allowed one of them"),
    ],
)
def test_sweep_mistakes_exit_2_naming_the_key_before_any_run(options, message, tmp_path, capsys):
    assert main(["sweep", "corner", "--out", str(tmp_path / "out"), *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith("slipnav: error: ") and message in err, err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out" / "sweep-corner.csv").exists()


def test_resume_refuses_another_sweeps_file(tmp_path, capsys):
    (tmp_path / "sweep-corner.csv").write_text("key,scenario,seed,x\nscenario=corner;seed=0,corner,0,1.5\n")
    argv = ["sweep", "corner", "--set", "follower.k2=2", "--workers", "0", "--out", str(tmp_path), "--resume"]
    assert main(argv) == 2
    assert "has no column 'set:follower.k2'" in capsys.readouterr().err
    (tmp_path / "sweep-corner.csv").write_bytes(b"\xff\xfe not a csv\n")
    assert main(argv) == 2
    assert "is not a sweep results file" in capsys.readouterr().err
    assert (tmp_path / "sweep-corner.csv").read_bytes() == b"\xff\xfe not a csv\n"  # left as it was


def _squared_seed(job: dict) -> dict:
    return {"x": job["seed"] ** 2 + 0.5}


def _lines(path) -> list[list[str]]:
    return [line.split(",") for line in path.read_text().splitlines()]


def test_resume_runs_again_the_lines_of_another_code_or_scenario_version(tmp_path, monkeypatch):
    path, scenario = tmp_path / "r.csv", tmp_path / "s.yaml"
    scenario.write_text("robot: tinyphoon\n")
    jobs = [{"scenario": str(scenario), "seed": seed} for seed in range(3)]

    def run(resume=True):
        stream = io.StringIO()
        rows = engine.run_jobs(_squared_seed, jobs, workers=0, results=path, resume=resume, stream=stream)
        return [row["x"] for row in rows], stream.getvalue()

    assert run(resume=False)[0] == [0.5, 1.5, 4.5]
    header, *lines = _lines(path)
    assert header == ["key", "code_version", "scenario", "seed", "x"]
    version = results_file.run_version(jobs[0])
    assert [line[1] for line in lines] == [version] * 3 and len(version) == 12
    # seed 0's line as this version wrote it (its value is read back), seed 1's by another version
    lines[0][4], lines[1][1], lines[1][4] = "7.0", "0123456789ab", "99.0"
    path.write_text("\n".join(",".join(cells) for cells in [header, *lines]) + "\n")
    x, progress = run()
    assert x == [7.0, 1.5, 4.5]
    assert "2 finished runs resumed; 1 lines of another code or scenario version run again" in progress
    assert [line[0] for line in _lines(path)[1:]] == [f"scenario={scenario};seed={s}" for s in (0, 2, 1)]
    # an edited scenario file: every run again, each key once
    scenario.write_text("robot: kurt3d\n")
    assert results_file.run_version(jobs[0]) != version
    x, progress = run()
    assert x == [0.5, 1.5, 4.5] and "3 lines of another code or scenario version" in progress
    assert len(_lines(path)) == 4 and {line[1] for line in _lines(path)[1:]} == {
        results_file.run_version(jobs[0])
    }
    # another release of the package: the same
    monkeypatch.setattr(results_file, "code_fingerprint", lambda: "upgraded")
    assert run()[1].count("3 lines of another code") == 1
    # an older release's file, without the code_version column: started anew
    path.write_text(
        "key,scenario,seed,x\n"
        + "".join(f"scenario={scenario};seed={s},{scenario},{s},9\n" for s in range(3))
    )
    x, progress = run()
    assert x == [0.5, 1.5, 4.5] and "3 lines of another code" in progress
    assert _lines(path)[0] == header and len(_lines(path)) == 4


def test_the_summary_gives_no_ratio_over_a_baseline_that_ended_on_the_truth():
    """fused/best is the mean fused error over the mean better baseline: 0.2 / 0.1 = 2; a baseline that
    ended exactly on the truth (a run too short to move) gives '-', not inf and a RuntimeWarning."""
    jobs = [{"seed": 0}, {"seed": 1}]
    rows = [
        {"fused_pct": 0.1, "odometry_pct": 0.05, "gyrodometry_pct": 0.3, "completed": True},
        {"fused_pct": 0.3, "odometry_pct": 0.4, "gyrodometry_pct": 0.15, "completed": False},
    ]
    lines, figures = sweep_study.summary_table("probe", jobs, rows)
    assert lines[-1].split()[-2:] == ["2.000", "1"]  # (0.1 + 0.3) / (0.05 + 0.15); one incomplete
    assert figures == {"mean_fused_pct": pytest.approx(0.2), "worst_fused_pct": 0.3}
    still = [dict(r, odometry_pct=0.0) for r in rows]
    assert sweep_study.summary_table("probe", jobs, still)[0][-1].split()[-2:] == ["-", "1"]


def test_the_summary_states_the_fused_rms_and_maximum_beside_the_final_error():
    """By hand: two seeds whose fused error ends at 0.1 and 0.2 % of the path after an RMS of 0.3 and 0.5 %
    and a maximum of 0.9 and 1.5 % along the run: mean (worst) 0.400 (0.500) and 1.200 (1.500)."""
    jobs = sweep_study.sweep_jobs("corner", {}, 2)
    rows = [
        {"fused_pct": final, "odometry_pct": 1.0, "gyrodometry_pct": 0.5, "completed": True}
        | {"fused_rms_pct": rms, "fused_max_pct": largest}
        for final, rms, largest in ((0.1, 0.3, 0.9), (0.2, 0.5, 1.5))
    ]
    lines, figures = sweep_study.summary_table("corner", jobs, rows)
    assert "RMS and maximum along the run" in lines[0]
    assert f"{'Gyrodom. %':>16}{'fused RMS %':>16}{'fused max %':>16}{'fused/best':>11}" in lines[1]
    assert f"{'0.500 (0.500)':>16}{'0.400 (0.500)':>16}{'1.200 (1.500)':>16}{'0.300':>11}" in lines[2]
    assert lines[2].startswith("as is") and f"{'0.150 (0.200)':>16}" in lines[2]
    assert figures == {"mean_fused_pct": pytest.approx(0.15), "worst_fused_pct": 0.2}
