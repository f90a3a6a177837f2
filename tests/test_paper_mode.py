"""Paper mode (scenarios/paper.py): every switch set to the print, and each block then computes the
papers' equation as printed (numbers by hand from Seyr & Jakubek S(n) and Indiveri et al. I(n))."""

import json
import math
import re

import numpy as np
import pytest
from slipnav.scenarios.config import load_scenario, scenario_from_yaml, with_keys
from slipnav.scenarios.paper import DEVIATIONS, paper_mode
from slipnav.scenarios.trajectories import PathConfig, Straight, build_path
from slipnav.studies.cli import main
from slipnav.systems.control.path_follower import PathFollowerParameters, follower_step
from slipnav.systems.control.slip_control import StepSizeController, StepSizeParameters
from slipnav.systems.health import health_initial_state, health_step
from slipnav.systems.navigation.gyrodometry import gyrodometry_step
from slipnav.systems.navigation.mixing.mixer import mix
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.weights import accumulate_delta_v, c3_residual, mixing_c1, mixing_c3
from slipnav.systems.navigation.parameters import NavigationParameters, health_geometry
from slipnav.systems.navigation.slip_detector import slip_detector_batch_end, slip_detector_step
from slipnav.systems.navigation.yaw_calibration import calibrated_gyro, calibrated_odometry

from tests.shared import scenario_result

T_N = 0.002
PAPER = paper_mode(load_scenario("corner"))


def test_paper_mode_sets_every_switch_and_keeps_the_rest():
    p, nav = PAPER, PAPER.navigation
    assert p.paper and p.standstill_time == 0.0
    assert (nav.health.enabled, nav.yaw_calibration.enabled) == (False, False)
    m = nav.mixing
    assert (m.delta_v_running_integral, m.dv_memory, m.c3_residual_time_constant) == (False, 0.0, 0.0)
    assert (m.a3, m.b3) == (60.0, 0.05)  # S(14) on single samples (the default 200, 0.02 suit the PT1)
    assert (m.odometry_slip_compensation, m.side_slip_from_accelerations) == (False, False)
    assert math.isinf(m.tyre_peak_acceleration) and m.q2_inertial == 1.0
    assert math.isinf(m.gyro_turn_rate) and nav.standstill.enabled is False
    assert nav.gyrodometry.rate_time_constant == 0.0
    assert p.slip_control.delayed_step_size is False and p.follower.delayed_speed_law is False
    assert p.follower.use_estimated_speed is True  # I(15)-(16) on the robot's speed: I(17) holds
    # The rest is the scenario's: tuning the papers give no number for, and T_N, T_C = the papers' 2, 20 ms.
    default = load_scenario("corner")
    assert (m.b1, m.a1, m.p, m.q2) == (default.navigation.mixing.b1, 150.0, 0.5, 0.99)
    assert (p.T_N, p.T_C, p.slip_control.delta_min) == (0.002, 0.02, default.slip_control.delta_min)
    assert paper_mode(PAPER) == PAPER  # idempotent
    kurt = paper_mode(load_scenario("circle")).navigation.mixing
    assert (kurt.a3, kurt.b3) == (200.0, 0.4)  # a scenario's own C3 thresholds are kept
    assert math.isinf(kurt.gyro_turn_rate)  # ... but not its turn rule (default: 0.05 rad/s)


def test_paper_key_in_yaml_and_set_equals_paper_mode():
    text = "paper: true\ntrajectory:\n  segments:\n    - !Straight {length: 0.5, v_end: 1.0}\n"
    loaded = scenario_from_yaml(text, name="x")
    plain = scenario_from_yaml(text.replace("paper: true\n", ""), name="x")
    assert loaded == paper_mode(plain)
    assert with_keys(plain, {"paper": True}) == loaded
    assert default_untouched(plain)


def default_untouched(scenario) -> bool:
    """Without ``paper`` every switch keeps today's behaviour."""
    m = scenario.navigation.mixing
    return (
        not scenario.paper
        and m.delta_v_running_integral
        and scenario.slip_control.delayed_step_size
        and scenario.follower.use_estimated_speed
        and scenario.follower.delayed_speed_law
    )


def test_every_switch_is_in_the_docs_table():
    """docs/paper-mode.md's table of deviations names every switch of DEVIATIONS."""
    docs = __import__("pathlib").Path(__file__).resolve().parent.parent / "docs"
    text = (docs / "paper-mode.md").read_text()
    table = text[text.index("### The deviations and their switches") : text.index("### What the print does")]
    for deviation in DEVIATIONS:
        assert f"`{deviation.key.split(':')[0]}`" in table, deviation.key


def test_s11_as_printed():
    """S(11): dv_K = (T_N/T_C) sum_k (^O v_t,k - ^O v_t,K-1 - (a_t1,k + a_t2,k) T_N/2). A batch of 3 with
    ^O v_t = 1.01, 1.02, 1.03 after 1.00 and a_t1 = a_t2 = 5 m/s^2 (0.01 m/s per sample): the printed
    terms are 0, 0.01, 0.02 -> dv = 0.01 m/s; the running integral (default) matches the odometry exactly:
    dv = 0."""

    def batch(running):
        state = [0.0, 0.0, 1.0, 0.0]
        for v in (1.01, 1.02, 1.03):
            state, total = slip_detector_step(state, v, [5.0, 0.0, 5.0, 0.0], T_N, running)
        return slip_detector_batch_end(state, 1.03, 3)[0]

    assert batch(PAPER.navigation.mixing.delta_v_running_integral) == pytest.approx(0.01, abs=1e-15)
    assert batch(True) == pytest.approx(0.0, abs=1e-15)


def test_s12_without_the_leaky_sum():
    """S(12): C1 = p C1_K-1 + (1 - p) / (1 + exp(a1 (|dv_K| - b1))); dv = 0.02 after a batch sum of 0.03:
    0.5 + 0.5 / (1 + e^-3) = 0.976287 (the default sees the sum 0.7 * 0.03 + 0.02 = 0.041 > b1)."""
    m = PAPER.navigation.mixing
    _, evidence = accumulate_delta_v(0.03, 0.02, m)
    assert mixing_c1(1.0, evidence, m) == pytest.approx(0.5 + 0.5 / (1.0 + math.exp(-3.0)), abs=1e-12)
    _, evidence = accumulate_delta_v(0.03, 0.02, MixingParameters())
    assert evidence == pytest.approx(0.041)


def test_s14_on_the_single_sample():
    """S(14): C3 = 1 / (1 + exp(a3 (|^O w_k - ^I w_k| - b3))): residual 0.3 - 0.2 = 0.1 rad/s whatever the
    past (no PT1), C3 = 1 / (1 + e^3) = 0.0474259 with a3 = 60, b3 = 0.05."""
    m = PAPER.navigation.mixing
    residual = c3_residual(0.5, 0.3, 0.2, m, T_N)
    assert residual == pytest.approx(0.1, abs=1e-15)
    assert mixing_c3(residual, m) == pytest.approx(1.0 / (1.0 + math.exp(3.0)), abs=1e-12)


def test_s15_to_s17_as_printed():
    """S(15) v_t = C1 ^O v_t + (1 - C1) ^I v_t = 0.25 + 0.675 = 0.925; S(16) w = 0.2 * 0.5 + 0.8 * 0.4 =
    0.42; S(17) v_n = C2 v_n,k-1 q2 + (1 - C2) ^I v_n = 0.5 * 0.02 * 0.99 + 0.5 * 0.05 = 0.0349; under
    3 m/s^2 of a_t and 4 m/s^2 of a_n, where the default's creep and tyre curve act."""
    odo, inertial, previous = [1.0, 0.5, 1.1, 0.9], [0.9, 0.05, 0.4, 3.0, 4.0], [1.0, 0.02, 0.5, 0.0, 0.0]
    mixed = mix(odo, inertial, 0.25, 0.5, 0.2, previous, PAPER.navigation.mixing)
    np.testing.assert_allclose(mixed, [0.925, 0.0349, 0.42, 3.0, 4.0], rtol=0, atol=1e-15)
    default = mix(odo, inertial, 0.25, 0.5, 0.2, previous, MixingParameters())
    assert abs(default[0] - 0.925) > 0.02  # the default takes the tyres' creep off ^O v_t


def test_raw_gyro_and_odometry_without_the_yaw_calibration():
    """S(3) and S(10)/S(14): the EKF gets the raw gyro and the mixer the raw odometry, whatever was
    learned (bias 0.01 rad/s, radius difference 1 %)."""
    cal = PAPER.navigation.yaw_calibration
    assert calibrated_gyro(0.3, [0.01, 0.01], cal) == 0.3
    assert calibrated_odometry([1.0, 0.2, 1.0068, 0.9932], [0.01, 0.01], 0.068, cal) == [
        1.0,
        0.2,
        1.0068,
        0.9932,
    ]


def test_no_sensor_checks_but_the_nan_guard():
    """No checks in S §IV: a 1000-count encoder spike and a 5 m/s^2 accelerometer jump pass as read; only
    a NaN is replaced (by the channel's last value)."""
    nav = PAPER.navigation
    g = health_geometry(nav, 0.015, 0.068, T_N)
    state = health_initial_state(g)
    state, out, codes = health_step(state, [0.1, 0.2, 0.1, 0.2, 0.05, 0.0, 0.0], nav.health, g)
    state, out, codes = health_step(state, [5.1, 0.2, 0.1, math.nan, 0.05, 1000.0, 0.0], nav.health, g)
    assert out == [5.1, 0.2, 0.1, 0.2, 0.05, 1000.0, 0.0]
    assert codes == [0, 0, 0, 1, 0, 0, 0]


def test_gyrodometry_algorithm_1_on_the_sample():
    """Algorithm 1: |d theta_odo| = 0.06 rad/s * T_N > c1 T_N = 0.05 T_N on this sample -> theta +=
    d theta_gyro - e = 0.05 T_N (e = 0). With the PT1 (default, 0.05 s) the filtered rate from 0 is
    0.06 (1 - e^-0.04) = 0.00235 rad/s < c1: the odometry's 0.06 T_N instead."""
    p = PAPER.navigation.gyrodometry
    state = gyrodometry_step([0.0, 0.0, 0.0, 0.0, 0.0], 1.0, 0.06, 0.05, p, T_N)
    assert state[2] == pytest.approx(0.05 * T_N, abs=1e-18)
    default = gyrodometry_step(
        [0.0, 0.0, 0.0, 0.0, 0.0], 1.0, 0.06, 0.05, NavigationParameters().gyrodometry, T_N
    )
    assert default[2] == pytest.approx(0.06 * T_N, abs=1e-18)


def test_s22_step_size_acts_at_once():
    """S(22) at K = 0 with delta_-1 = 1, C1 = 0.5, alpha = 0 (logsig = 0.98 > C1), K - Pi_K = 0 (S(23):
    bound 1): delta_0 = 1 * (0.75 + 0.5 * (1.05 - 0.75)) = 0.9, and S(25) paces the reference by delta_0
    at t_0 already; delayed (default) by delta_-1 = 1 until t_1."""

    def pace(delayed, t):
        params = StepSizeParameters(delayed_step_size=delayed)
        block = StepSizeController(params, 0.02)
        context = block.CreateDefaultContext()
        block.GetInputPort("C1").FixValue(context, [0.5])
        block.GetInputPort("side_slip_angle").FixValue(context, [0.0])
        context.SetTime(t)
        return block.GetOutputPort("pace").Eval(context)[0]

    assert pace(PAPER.slip_control.delayed_step_size, 0.0) == pytest.approx(0.9, abs=1e-15)
    assert pace(True, 0.0) == 1.0
    assert pace(False, 0.01) == 1.0  # between control instants: the step size set at t_K (here none yet)


def test_s22_reads_c1_and_alpha_of_the_same_instant():
    """S(22): delta_K = min(max(delta_K-1 (delta_min + min(C1_K, logsig(a4 (|alpha_K| - b4))) (q_delta -
    delta_min)), delta_min), delta_max,K) with C1_K and alpha_K of batch K, which the navigation computes
    at t_K (logged from row k + 1 on; row k holds C1_K-1, alpha_K-1). Corner, closed loop, 3 s: every
    delta_K of paper mode is S(22) of C1_K and alpha_K to the last bit, and misses it with C1_K-1,
    alpha_K-1 (slip control acts: the step size is cut); the default reads C1_K-1, alpha_K-1."""
    from slipnav.systems.control.slip_control import step_size

    def misses(scenario):
        """Largest |logged delta_K - S(22)| with the inputs of row k + 1 (this batch) and of row k."""
        a, p = scenario_result(scenario, duration=3.0).arrays, scenario.slip_control  # shared: animate's
        k0 = round(float(a["start_time"]) / T_N)
        rows = range(k0, len(a["t"]) - 1, 10)
        worst = {0: 0.0, 1: 0.0}
        for K, k in enumerate(rows):
            for shift in worst:
                j, lag = k + shift, K - a["progress"][k]
                delta = step_size(a["step_size"][k], a["C1"][j], a["est_alpha"][j], lag, p)
                worst[shift] = max(worst[shift], abs(delta - a["step_size"][k + 1]))
        assert min(a["step_size"]) == p.delta_min
        return worst

    paper = misses(PAPER)
    assert paper[1] == 0.0 and paper[0] > 0.05
    default = misses(load_scenario("corner"))
    assert default[0] == 0.0 and default[1] > 0.05


def test_i16_with_the_robots_speed():
    """I(16): s_dot = u cos(theta) + k1 s1 with u the robot's speed 0.5 m/s (paper mode and default; the
    command u = 1 m/s goes into I(18)-(19)): the robot 0.1 m ahead of the virtual target on a straight
    path, theta = 0, k1 = 2: s_dot = 0.5 + 0.2 = 0.7, s_+ = 0.7 * 0.02 = 0.014, and the commands u +- b *
    (kappa s_dot + theta_dot) = 1 +- 0 = 1 m/s. With the command in I(16) too (use_estimated_speed false):
    s_dot = 1.2, s_+ = 0.024."""
    path = build_path(PathConfig(segments=[Straight(length=5.0)]))
    step = follower_step(0.0, (0.1, 0.0, 0.0), 1.0, path, PAPER.follower, 0.034, 0.02, u_measured=0.5)
    assert step[0] == pytest.approx(0.014, abs=1e-15) and step[1:3] == [1.0, 1.0]
    single_u = PathFollowerParameters(use_estimated_speed=False)
    step = follower_step(0.0, (0.1, 0.0, 0.0), 1.0, path, single_u, 0.034, 0.02, 0.5)
    assert step[0] == pytest.approx(0.024, abs=1e-15)


def test_i24_reads_v1_of_the_same_instant():
    """I(24) on a straight path (kappa_r = 0), Kurt3D's V_m = 4.1 m/s, b = 0.2 m, epsilon = 0.05: the
    robot at s = 1 m, 0.2 m left of the path, heading along it: delta = -0.5 tanh(0.2) = -0.0986877, V1 =
    0.2^2 / 2 + delta^2 / (2 * 0.5) = 0.0297393 < epsilon -> u = V_m = 4.1 m/s at once (paper mode). The
    follower's V1 of the previous update, 0.06 >= epsilon, sets u = V_m/2 = 2.05 m/s (default)."""
    from slipnav.systems.control.path_follower import WheelSpeedSaturator, speed_law

    path = build_path(PathConfig(segments=[Straight(length=5.0)]))
    paper = PathFollowerParameters(delayed_speed_law=PAPER.follower.delayed_speed_law)
    assert speed_law((1.0, 0.2, 0.0), 1.0, path, paper, 4.1, 0.2) == pytest.approx((4.1, 0.0297393), abs=1e-7)

    def u(params):
        block = WheelSpeedSaturator(path, 4.1, 0.4, params)
        context = block.CreateDefaultContext()
        for name, value in (("lyapunov_value", [0.06]), ("estimated_pose", [1.0, 0.2, 0.0])):
            block.GetInputPort(name).FixValue(context, value)
        block.GetInputPort("virtual_target").FixValue(context, [1.0])
        block.GetInputPort("wheel_speed_command").FixValue(context, [0.0, 0.0])
        return block.GetOutputPort("speed").Eval(context)[0]

    assert u(paper) == 4.1
    assert u(PathFollowerParameters()) == 2.05


def test_run_paper_writes_the_paper_stem_and_summary(tmp_path, capsys):
    assert (
        main(["run", "corner", "--paper", "--duration", "0.2", "--no-figures", "--out", str(tmp_path)]) == 0
    )
    summary = json.loads((tmp_path / "corner-seed0-paper.summary.json").read_text())
    assert summary["paper"] is True and summary["standstill_s"] == 0.0
    assert main(["run", "corner", "--duration", "0.2", "--no-figures", "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "corner-seed0.summary.json").read_text())["paper"] is False


def test_paper_effects_variants():
    """The study runs the default, paper mode and each deviation alone; the control ones closed loop only."""
    from slipnav.studies.paper_effects import CONTROL_DEVIATIONS, scenario_of, variants

    assert variants(False)[:2] == ["default", "paper"] and len(variants(False)) == 2 + len(DEVIATIONS)
    assert "only step_size_delay" not in variants(True)
    assert len(variants(True)) == 2 + len(DEVIATIONS) - len(CONTROL_DEVIATIONS)
    alone = scenario_of("corner", "only creep")
    assert not alone.navigation.mixing.odometry_slip_compensation and not alone.paper
    assert alone.navigation.mixing.dv_memory == 0.7  # the rest stays the default


def test_paper_effects_reports_final_rms_and_max_position_error(monkeypatch, capsys):
    """Per variant and loop, the study returns and prints the fused position error's final value, RMS
    and maximum in % of the path: those metrics.position_errors_in_percent computes on the runs' own
    arrays (kept here as the study runs them), with RMS <= max and final <= max (the corner ends at rest).
    The default and paper mode, corner, seed 0, closed and open loop."""
    from slipnav.scenarios.metrics import position_errors_in_percent
    from slipnav.studies import paper_effects as study

    real_run, arrays = scenario_result, {}  # the runs, shared (tests/shared.py)

    def run(scenario, **kwargs):
        result = real_run(scenario, **kwargs)
        arrays[(kwargs["open_loop"], scenario.paper)] = result.arrays
        return result

    monkeypatch.setattr(study, "run_scenario", run)
    monkeypatch.setattr(study, "variants", lambda open_loop: ["default", "paper"])
    out = study.paper_effects(["corner"], 1, workers=0)
    table = capsys.readouterr().out
    assert set(out) == {("corner", loop, v) for loop in (False, True) for v in ("default", "paper")}
    for (_, open_loop, variant), figures in out.items():
        assert list(figures) == list(study.FIGURES) and all(len(v) == 1 for v in figures.values())
        final, rms, largest = (float(figures[f][0]) for f in ("final_pct", "rms_pct", "max_pct"))
        expected = position_errors_in_percent(arrays[(open_loop, variant == "paper")], "est")
        assert (final, rms, largest) == pytest.approx((expected["final"], expected["rms"], expected["max"]))
        assert 0.0 < rms <= largest and final <= largest
        loop = "open" if open_loop else "closed"
        shown = rf"final\s+{final:5.2f} \({final:4.2f}\)\s+RMS\s+{rms:5.2f} \({rms:4.2f}\)\s+"
        shown += rf"max\s+{largest:5.2f} \({largest:4.2f}\)\s+alpha "
        assert re.search(rf"corner\s+{loop}\s+{variant}\s+{shown}", table), (loop, variant)
    # paper mode's fused estimate is further off along the run than the default's, closed loop
    assert out[("corner", False, "paper")]["rms_pct"][0] > out[("corner", False, "default")]["rms_pct"][0]
