"""Mixing of odometric and inertial estimates, Seyr & Jakubek §IV-D: C1 S(12), C2 S(13), C3 S(14) and
the mixing laws S(15)-(17), whose result is fed back into the EKF (Fig. 3).

S(17) relaxes v_n towards zero while |a_n| < b2 and integrates it above. Rubber tyres side-slip from the
first m/s^2 of lateral acceleration, increasingly so towards the friction limit, so here v_n relaxes towards
the side slip of the tyre curve instead: strongly below b2 (q2) towards the steady-turn slip at v_t omega
(lateral_velocity_model), weakly above (q2_inertial) towards the slip at the forces the accelerometers
measure (side_slip_from_accelerations). tyre_peak_acceleration = inf and q2_inertial = 1 restore the
paper's S(17).
Likewise the tyres creep ahead of the body whenever they push (traction, the drag of the felt shoes, a
sliding turn): S(15) takes the same tyre curve's longitudinal slip off the odometric v_t
(longitudinal_slip_speed; odometry_slip_compensation = False restores the paper's S(15)).
The tyre curve is the nominal robot's; a floor with less grip lets the body slide past where that curve
says. A free integral of the EKF's lateral kinematics (anchored to the estimate while the tyres carry
little force, where the curve is right whatever the floor) weighs the two: where it departs from the
curve's side slip by more than tyre_model_gate_deg, S(17)'s inertial branch is pulled towards the free
integral instead (tyre_model_check, free_side_slip_step).
"""

import copy
import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.health.accelerometer_pair import pair_rotational_difference
from slipnav.systems.rates import pt1_step
from slipnav.systems.standstill import zero_velocity_update


@dc.dataclass
class MixingParameters:
    """Tuning of the mixing parameters (rationale in the paper's spirit, §IV-D).

    Args:
        a1: C1 steepness (s/m): as steep as possible, flat enough to avoid limit cycles; 150 gives a
            10 %-90 % transition over 0.03 m/s of dv.
        b1: C1 threshold (m/s): as small as possible but above the dv produced by accelerometer bias and
            encoder quantisation (~5 mm/s per batch).
        p: PT1 pole of C1: as fast as possible without limit cycles; 0.5 halves the gap every T_C.
        dv_memory: weight of the earlier batches in the accumulated speed difference that C1 also sees
            (accumulate_delta_v, an extension of S(12)): a wheel lock that builds up over several batches,
            each below b1, sums up to the slip speed itself. 0.7 (~3 batches): long enough to catch the
            square's gradual locks (closed loop 78/83 -> 78/78 episodes, all within 1 T_C, 10 seeds),
            short enough that the inertial v_t taken meanwhile hardly drifts (accelerometer bias sums to
            3.3 x its ~0.4 mm/s per batch, far below b1). 0: the paper's S(12).
        delta_v_running_integral: S(11)'s acceleration term is the running integral of the mean
            tangential acceleration since the batch start ("discrete integration", §IV-C; systems/
            slip_detector.py). False: the printed single-sample term (a_t1,k + a_t2,k) T_N/2.
        a2: C2 steepness (s^2/m): 4 gives a 10 %-90 % transition over 1.1 m/s^2.
        b2: C2 threshold on |a_n| (m/s^2): above the EKF's a_n noise (commotion) at speed.
        a3: C3 steepness (s/rad): 200 gives a 10 %-90 % transition over 0.022 rad/s.
        b3: C3 threshold on |^O omega - ^I omega| (rad/s), after the PT1 below: 0.02. The single-sample
            odometric yaw rate is quantised in steps of 0.11 rad/s (7.7 mm/s / 68 mm); filtered over one
            T_C its error is < 0.011 rad/s and the gyro's noise 0.003 rad/s, while the felt shoes' 1-2 %
            scrub in a 3 rad/s spot turn gives 0.03-0.06 rad/s: with the gyro's bias estimated
            (systems/gyro_bias.py) the turn is the gyro's (square, 10 seeds: fused heading error RMS
            1.5 -> 0.3 deg open loop).
        c3_residual_time_constant: PT1 of ^O omega - ^I omega before S(14) (s): 0.02 (one T_C, the
            batch of S(11)); 0: the paper's per-sample residual. The turn rate below is filtered alike.
        gyro_turn_rate: |^I omega| (PT1-filtered as the residual) above which the yaw rate is the gyro's
            whatever the disagreement (rad/s; mixing_c3): a turn's heading change is scaled by the
            odometric yaw rate's error (the track's tolerance, +-3 %: the tyres' contact patches) or by
            the gyro's (its sensitivity's, +-1 %), and the smaller bound wins (Gyrodometry's rule, I
            Algorithm 1). Needed where the disagreement cannot tell a turn (Kurt3D: its encoders' 0.15 rad/s
            steps set b3 above a 3 % track error); inf: S(14) alone (default: Tinyphoon's scrub already
            hands its turns to the gyro).
        q2: geometric relaxation of v_n towards the tyre model per T_N while |a_n| < b2, S(17): as small
            as possible but large enough for consistent velocity (0.99 -> 0.2 s time constant).
        q2_inertial: the same for the inertial v_n, weighted 1 - C2 (|a_n| > b2), at zero tyre force;
            the pull fades with the tyre curve's slope factor sqrt(1 - (|a|/a_peak)^2) to nothing at the
            friction limit, where any slip angle past the peak gives about the same force. Below 1 so that
            the side slip of a hard turn is held to the tyre curve rather than integrated with the
            accelerometers' commotion and bias (0.3 m/s^2 rms at 1.6 m/s: ~0.03 m/s, 1 deg, over a 0.5 s
            turn); close to 1 because the tyre curve is quasi-static (0.95 -> 40 ms at small |a|). 1: the
            paper's S(17).
        side_slip_from_accelerations: the inertial branch's pull targets the side slip at the tyre force
            the accelerometers measure (side_slip_from_accelerations), rather than the steady-turn slip at
            v_t omega (lateral_velocity_model). The force follows the slip angle, not v_t omega: it lags
            v_t omega while the slip builds up, overshoots while it decays, and drops when the tyres
            brake or drive (the friction circle), which v_t omega cannot know (corner alpha RMS, 10
            seeds: open loop 1.17 -> 0.49 deg, closed loop 0.52 -> 0.34 deg). False: the steady-turn
            slip.
        tyre_peak_acceleration: the tyres' largest lateral acceleration mu g f_w (m/s^2), identified with
            the two shape factors below from steady turns. Default: Tinyphoon, 0.7 * 9.81 * 0.8 = 5.49.
            inf: no side slip (the paper's S(17) relaxes v_n to zero).
        tyre_stiffness_factor: Pacejka B of the lateral tyre curve (1/rad). Default: Tinyphoon, 15.
        tyre_shape_factor: Pacejka C, in (1, 2). Default: Tinyphoon, 1.3.
        odometry_slip_compensation: take the tyres' steady longitudinal slip off ^O v_t in S(15)
            (longitudinal_slip_speed). Rubber tyres creep ahead of the body whenever they push: 1.5 % at
            1.6 m/s^2, 0.04 m/s at the end of the corner's launch, 0.08 m/s in its sliding turn (v_t rms
            error 26 -> 8 mm/s and its mean 15 -> 0 mm/s on the open corner, 10 seeds). False: the paper's
            S(15).
        drag_acceleration: the resistance the tyres push against at any speed, per unit mass (m/s^2):
            Tinyphoon's felt shoes, mu_shoe (1 - f_w) g = 0.25 * 0.2 * 9.81 = 0.49; 0 without shoes.
        drag_per_speed: the resistance's growth with speed (1/s): Tinyphoon's shoes, 2 * 0.05 N s/m /
            0.4 kg = 0.25; 0 without shoes.
        tyre_reference_speed: the slip ratio's reference speed floor (m/s): below it the slip speed is
            kappa times this speed (a regularised slip, as the tyre curve was identified). Default 0.3.
        tyre_model_gate_deg: disagreement (deg of side slip) between the free integral of the lateral
            kinematics (free_side_slip_step) and the tyre curve's side slip at which S(17)'s inertial
            branch trusts the integral instead of the curve (tyre_model_check; weight 0.48 there). The
            nominal curve does not know the floor: at friction 0.5 the corner's body slides to 7 deg where
            the curve says 2.7, and the integral, anchored before the slide, departs from the curve by 4-5
            deg; on the matched robot it stays within 1.5 deg (its drift). 2.5: between the two (10
            seeds, closed loop, friction 0.5: side slip RMS 2.82 -> 2.07 deg on the corner, 6.5 -> 1.7
            deg on the long path; the matched corner bit for bit as without). inf: the curve alone.
        tyre_model_gate_steepness: steepness of that weight's logsig (1/deg): 3 gives 10 %-90 % from
            1.9 to 3.25 deg (the logsig rescaled to 0 at 1 deg below the gate).
        tyre_model_gate_speed: the slowest speed the gate's degrees refer to (m/s): the disagreement is
            |F - S| / max(|v_t|, this). 1: a slide matters at speed, and at 0.4 m/s the accelerometers'
            commotion (or a fault in the 60 ms before the sensor checks exclude it) over a few samples
            is several degrees.
        free_side_slip_time_constant: the free integral relaxes towards the estimate with this time
            constant (s) while it is not anchored, which bounds its drift (the accelerometers' bias
            integrated; Kurt3D's turns last seconds): 0.25, slow against a slide's build-up (60-100 ms).
        free_side_slip_anchor: lateral tyre utilisation |^I a_n| / a_peak below which the free integral
            is the estimate itself (anchored): 0.2 (Tinyphoon 1.1 m/s^2), where the side slip is below
            1 deg whatever the friction, and above a braking lock's lateral commotion (0.25 m/s^2).
        slide_onset_jump: the per-sample wheel-speed test (slide_onset_step): when the odometric v_t
            changes in one T_N by more than this (m/s) beyond what ^I a_t T_N allows, the wheels have
            left the body (a lock or a spin: 0.05 m/s in 2 ms is 25 m/s^2, four times the tyres' peak),
            and S(15) takes v_t from the inertial estimate alone (C1 = 0) from this sample on, while
            S(11)'s batch of T_C still fills. inf (default): off, S(12)'s C1 alone. 0.05 suits Tinyphoon
            (6.5 of its 7.7 mm/s encoder quanta per sample; README, Navigation: why it is not the
            default yet); at least 3 quanta (check_slide_onset).
        slide_onset_release: the test releases when the odometric v_t has agreed with ^I v_t within
            this (m/s) for slide_onset_release_samples samples in a row: 0.03.
        slide_onset_release_samples: 5 (10 ms).
        slide_onset_max_time: the test releases after this long (s) whatever the agreement, which
            bounds the inertial v_t's drift (the accelerometers' bias and scale): 0.5.
        slide_onset_pair_tolerance: the test trusts the accelerometers only while their two t axes
            agree within this (m/s^2) beyond the centripetal difference 2 omega^2 x of S(3)
            (accelerometer_pair_disagreement; 1.5, 3.5 sigma of their noise and commotion at 2 m/s): a
            channel that fails before the sensor checks exclude it (a clipped reading, 60 ms) would
            otherwise be integrated alone. After the exclusion the replacement agrees by construction.
        tyre_peak_identification: identify a_peak online from the navigation's own sensors
            (tyre_peak_step; issue 15: the floor's grip is not the data sheet's) and use it for the tyre
            curve of S(15) and S(17), starting from tyre_peak_acceleration (the nominal or calibrated
            value). False: tyre_peak_acceleration throughout.
        tyre_peak_force_time_constant: PT1 of the tyres' force per unit mass |a| whose value the peak is
            at least (s): 0.1, where the built-ins' matched runs stay below their peak (0.05: the long
            path's 1.02 x) and their friction-0.5 runs read 0.99-1.03 x it.
        tyre_peak_hold_time: that lower bound is held with this decay time constant (s): 10, long
            against a slide's end, when the free integral's slip lags the force (an open corner at
            friction 0.5 otherwise reads a_peak at 0.7 x), short against a change of floor.
        tyre_peak_evidence_slip: share of the curve's peak slip sigma_peak (peak_slip) from which a sample
            is evidence of the peak (its weight rises linearly from 0 here to 1 at
            tyre_peak_full_evidence_slip): 0.4. Below, the free integral's drift (1-1.5 deg) makes
            |a| / share(sigma) read 0.84 x the peak (matched corner, sigma 0.3-0.4 sigma_peak); from 0.4
            on the median read is within 0.94-1.02 x on the matched and friction-0.5 built-ins.
        tyre_peak_full_evidence_slip: share of sigma_peak from which a sample weighs in fully: 0.9 (the
            curve's share there is 0.999, so the read is |a| within its scatter).
        tyre_peak_identification_time_constant: time constant with which a_peak follows the evidence at
            full weight (s): 0.05, 25 samples against the per-sample read's scatter (+-15 %).
        tyre_peak_candidate_bound: one sample's read |a| / share is limited to within a_peak (1 + this)
            and a_peak / (1 + this): 0.2, which bounds what one mistaken slip moves.
        tyre_peak_min_ratio: the identified a_peak is at least this multiple of tyre_peak_acceleration:
            0.5 (friction 0.35 on Tinyphoon's nominal 0.7).
        tyre_peak_max_ratio: and at most this multiple: 1.5 (friction 1.05), which also bounds what a
            push on the body, read as tyre force, raises the lower bound to.
    """

    a1: float = 150.0
    b1: float = 0.04
    p: float = 0.5
    dv_memory: float = 0.7
    delta_v_running_integral: bool = True
    a2: float = 4.0
    b2: float = 2.0
    a3: float = 200.0
    b3: float = 0.02
    c3_residual_time_constant: float = 0.02
    gyro_turn_rate: float = math.inf
    q2: float = 0.99
    q2_inertial: float = 0.95
    side_slip_from_accelerations: bool = True
    tyre_peak_acceleration: float = 5.49
    tyre_stiffness_factor: float = 15.0
    tyre_shape_factor: float = 1.3
    odometry_slip_compensation: bool = True
    drag_acceleration: float = 0.49
    drag_per_speed: float = 0.25
    tyre_reference_speed: float = 0.3
    tyre_model_gate_deg: float = 2.5
    tyre_model_gate_steepness: float = 3.0
    tyre_model_gate_speed: float = 1.0
    free_side_slip_time_constant: float = 0.25
    free_side_slip_anchor: float = 0.2
    slide_onset_jump: float = math.inf
    slide_onset_release: float = 0.03
    slide_onset_release_samples: int = 5
    slide_onset_max_time: float = 0.5
    slide_onset_pair_tolerance: float = 1.5
    tyre_peak_identification: bool = True
    tyre_peak_force_time_constant: float = 0.1
    tyre_peak_identification_time_constant: float = 0.05
    tyre_peak_evidence_slip: float = 0.4
    tyre_peak_full_evidence_slip: float = 0.9
    tyre_peak_candidate_bound: float = 0.2
    tyre_peak_hold_time: float = 10.0
    tyre_peak_min_ratio: float = 0.5
    tyre_peak_max_ratio: float = 1.5

    def __post_init__(self):
        for name in ("a1", "b1", "a2", "b2", "a3", "b3", "tyre_stiffness_factor"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed (0, inf)")
        for name in ("p", "q2", "dv_memory"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v < 1.0) or (name == "q2" and v == 0.0):
                bracket = "(0, 1)" if name == "q2" else "[0, 1)"
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed {bracket}")
        tau = self.c3_residual_time_constant
        if not (math.isfinite(tau) and tau >= 0.0):
            raise ValueError(f"mixing.c3_residual_time_constant={tau!r} is out of range: allowed [0, inf) s")
        if not self.gyro_turn_rate >= 0.0:  # also rejects NaN; inf: S(14) alone
            raise ValueError(
                f"mixing.gyro_turn_rate={self.gyro_turn_rate!r} is out of range: allowed [0, inf] rad/s"
            )
        if not 0.0 < self.q2_inertial <= 1.0:
            raise ValueError(f"mixing.q2_inertial={self.q2_inertial!r} is out of range: allowed (0, 1]")
        a = self.tyre_peak_acceleration
        if not a > 0.0:  # also rejects NaN; inf: no side slip, the paper's S(17)
            raise ValueError(f"mixing.tyre_peak_acceleration={a!r} is out of range: allowed (0, inf] m/s^2")
        c = self.tyre_shape_factor
        if not 1.0 < c < 2.0:
            raise ValueError(f"mixing.tyre_shape_factor={c!r} is out of range: allowed (1, 2)")
        for name in (
            "odometry_slip_compensation",
            "side_slip_from_accelerations",
            "delta_v_running_integral",
            "tyre_peak_identification",
        ):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(
                    f"mixing.{name}={getattr(self, name)!r} is out of range: allowed true, false"
                )
        gate = self.tyre_model_gate_deg
        if not gate > 0.0:  # also rejects NaN; inf: the tyre curve alone
            raise ValueError(f"mixing.tyre_model_gate_deg={gate!r} is out of range: allowed (0, inf] deg")
        for name in (
            "tyre_model_gate_steepness",
            "tyre_model_gate_speed",
            "free_side_slip_time_constant",
            "tyre_peak_force_time_constant",
            "tyre_peak_hold_time",
            "tyre_peak_identification_time_constant",
            "tyre_peak_candidate_bound",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed (0, inf)")
        if not (math.isfinite(self.free_side_slip_anchor) and 0.0 < self.free_side_slip_anchor < 1.0):
            raise ValueError(
                f"mixing.free_side_slip_anchor={self.free_side_slip_anchor!r} is out of range: allowed (0, 1)"
            )
        for name in ("drag_acceleration", "drag_per_speed", "tyre_reference_speed"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0.0):
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed [0, inf)")
        if not self.slide_onset_jump > 0.0:  # also rejects NaN; inf: no per-sample test
            raise ValueError(
                f"mixing.slide_onset_jump={self.slide_onset_jump!r} is out of range: allowed (0, inf] m/s"
            )
        for name, unit in (
            ("slide_onset_release", "m/s"),
            ("slide_onset_max_time", "s"),
            ("slide_onset_pair_tolerance", "m/s^2"),
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"mixing.{name}={v!r} is out of range: allowed (0, inf) {unit}")
        lo, hi = self.tyre_peak_evidence_slip, self.tyre_peak_full_evidence_slip
        if not (math.isfinite(lo) and lo > 0.0):
            raise ValueError(f"mixing.tyre_peak_evidence_slip={lo!r} is out of range: allowed (0, inf)")
        if not (math.isfinite(hi) and hi > lo):
            raise ValueError(
                f"mixing.tyre_peak_full_evidence_slip={hi!r} is out of range: allowed "
                f"(tyre_peak_evidence_slip={lo!r}, inf)"
            )
        lo, hi = self.tyre_peak_min_ratio, self.tyre_peak_max_ratio
        if not (math.isfinite(lo) and 0.0 < lo <= 1.0):
            raise ValueError(f"mixing.tyre_peak_min_ratio={lo!r} is out of range: allowed (0, 1]")
        if not (math.isfinite(hi) and hi >= 1.0):
            raise ValueError(f"mixing.tyre_peak_max_ratio={hi!r} is out of range: allowed [1, inf)")
        n = self.slide_onset_release_samples
        if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 1000:
            raise ValueError(
                f"mixing.slide_onset_release_samples={n!r} is out of range: allowed an integer in [1, 1000]"
            )


def logsig(a: float, x: float, b: float) -> float:
    """1 / (1 + exp(a (x - b))), the switch of S(12)-(14) (1: odometric, 0: inertial); overflow-safe."""
    z = a * (x - b)
    if z > 0:
        e = math.exp(-z)
        return e / (1.0 + e)
    return 1.0 / (1.0 + math.exp(z))


def mixing_c1(c1_prev: float, delta_v: float, p: MixingParameters) -> float:
    """S(12): C1_K = p C1_K-1 + (1 - p) logsig(a1 (|dv_K| - b1))."""
    return p.p * c1_prev + (1.0 - p.p) * logsig(p.a1, abs(delta_v), p.b1)


def accumulate_delta_v(accumulated: float, delta_v: float, p: MixingParameters) -> tuple[float, float]:
    """Leaky sum of S(11)'s batch speed differences, A_K = dv_memory A_K-1 + dv_K, and the value that
    S(12)'s logsig sees instead of |dv_K|: max(|dv_K|, |A_K|) (|dv_K| alone for dv_memory = 0, the paper).

    Returns:
        (A_K, max(|dv_K|, |A_K|))
    """
    accumulated = p.dv_memory * accumulated + delta_v
    return accumulated, max(abs(delta_v), abs(accumulated))


def mixer_c1_step(c1_prev: float, accumulated: float, delta_v: float, p: MixingParameters):
    """One T_C update of the C1 mixer: (C1_K, A_K) from S(11)'s dv_K (accumulate_delta_v, mixing_c1).
    A NaN dv_K (every sample of the batch failed a sensor check, slip_detector_delta_v) is no evidence:
    C1 and A hold. Reading it as dv = 0 would hand v_t back to the odometry whenever S(11) is blind (an
    encoder excluded in a braking slide: open square, 4.5 x the fault-free error).

    Returns:
        (C1_K, A_K)
    """
    if math.isnan(delta_v):
        return c1_prev, accumulated
    accumulated, evidence = accumulate_delta_v(accumulated, delta_v, p)
    return mixing_c1(c1_prev, evidence, p), accumulated


def mixing_c2(inertial_a_n: float, p: MixingParameters) -> float:
    """S(13): C2 = logsig(a2 (|^I a_n| - b2))."""
    return logsig(p.a2, abs(inertial_a_n), p.b2)


def c3_residual(
    previous: float, odometric_omega: float, inertial_omega: float, p: MixingParameters, T_N: float
):
    """^O omega - ^I omega, PT1-filtered with c3_residual_time_constant (0: this sample's, as in S(14))."""
    return pt1_step(previous, odometric_omega - inertial_omega, p.c3_residual_time_constant, T_N)


def c3_turn_rate(previous: float, inertial_omega: float, p: MixingParameters, T_N: float) -> float:
    """^I omega, PT1-filtered with c3_residual_time_constant: the turn rate mixing_c3 tests."""
    return pt1_step(previous, inertial_omega, p.c3_residual_time_constant, T_N)


def mixing_c3(residual: float, p: MixingParameters, turn_rate: float = 0.0) -> float:
    """S(14): C3 = logsig(a3 (|^O omega - ^I omega| - b3)), on the (filtered) residual of c3_residual;
    in a turn (|turn_rate| above gyro_turn_rate, c3_turn_rate) times logsig(a3 (|turn_rate| -
    gyro_turn_rate)), which hands the turn to the gyro."""
    c3 = logsig(p.a3, abs(residual), p.b3)
    if math.isinf(p.gyro_turn_rate):
        return c3
    return c3 * logsig(p.a3, abs(turn_rate), p.gyro_turn_rate)


def tyre_utilisation(v_t: float, omega: float, p: MixingParameters) -> float:
    """|a_n| / a_peak with the steady-turn lateral acceleration a_n = v_t omega, capped at 1."""
    return min(abs(v_t * omega) / p.tyre_peak_acceleration, 1.0)


def tyre_slip(utilisation: float, p: MixingParameters) -> float:
    """The inverse magic formula: the slip sigma = tan(asin(u) / C) / B at which the tyre curve
    a_peak sin(C atan(B sigma)) gives the share u (<= 1) of its peak."""
    return math.tan(math.asin(utilisation) / p.tyre_shape_factor) / p.tyre_stiffness_factor


def lateral_velocity_model(v_t: float, omega: float, p: MixingParameters) -> float:
    """Side-slip velocity v_n in a steady turn at lateral acceleration a_n = v_t omega (S(2) with
    dv_n/dt = 0): the inverse of the lateral magic formula |a_n| = a_peak sin(C atan(B tan|alpha|)),
    tan(alpha) = v_n/|v_t|, capped at the peak (|a_n| >= a_peak); zero for a_peak = inf.

    In the linear range tan(alpha) = -a_n/K_alpha with K_alpha = a_peak B C (Tinyphoon: 107 m/s^2/rad).
    The two tyres are lumped at the axle centre, which holds while |omega| track/2 << |v_t|. v_t omega,
    from odometry and gyro, is used rather than the EKF's a_n: it carries none of the accelerometers'
    commotion (2.0 -> 0.5 mm/s rms v_n noise on the corner's straights)."""
    ratio = tyre_utilisation(v_t, omega, p)
    tan_alpha = tyre_slip(ratio, p)
    return -abs(v_t) * math.copysign(tan_alpha, v_t * omega)


DRAG_SPEED_SCALE = 0.01
"""m/s: the drag's direction follows tanh(v_t / DRAG_SPEED_SCALE) (Coulomb friction, regularised)."""


def tyre_force_per_mass(speed: float, a_t: float, a_n: float, p: MixingParameters) -> tuple[float, float]:
    """The tyres' force per unit mass (a_x, a_n) that accelerates the body at (a_t, a_n) against the
    drag at ``speed`` v: a_x = a_t + (drag_acceleration + drag_per_speed |v|) tanh(v / 0.01) (the shoes'
    small lateral drag, ~drag sin(alpha), is neglected)."""
    drag = p.drag_acceleration + p.drag_per_speed * abs(speed)
    return a_t + drag * math.tanh(speed / DRAG_SPEED_SCALE), a_n


def combined_slip(a_x: float, a_n: float, p: MixingParameters) -> tuple[float, float]:
    """Combined-slip magic formula (Pacejka's similarity method): the tyres that carry the force (a_x,
    a_n) per unit mass slip by sigma = tyre_slip(|a| / a_peak) (capped at the peak) in the force's
    direction. Returns (sigma, |a| / a_peak) (uncapped; 0, 0 for a_peak = inf)."""
    if math.isinf(p.tyre_peak_acceleration):
        return 0.0, 0.0
    utilisation = math.hypot(a_x, a_n) / p.tyre_peak_acceleration
    return tyre_slip(min(utilisation, 1.0), p), utilisation


def longitudinal_slip_speed(wheel_speed: float, a_t: float, a_n: float, p: MixingParameters) -> float:
    """Steady slip speed r theta_dot - v_t of the tyres that push the body at (a_t, a_n) against the drag.

    The combined slip (combined_slip) of the tyre force (tyre_force_per_mass at the wheel speed v) has the
    longitudinal part kappa = sigma a_x / |a|; the slip speed is kappa max(|v|, tyre_reference_speed).
    Zero for a_peak = inf or without odometry_slip_compensation. The two tyres are lumped (their mean
    slip)."""
    if not p.odometry_slip_compensation:
        return 0.0
    a_x, a_n = tyre_force_per_mass(wheel_speed, a_t, a_n, p)
    sigma, utilisation = combined_slip(a_x, a_n, p)
    if utilisation == 0.0:
        return 0.0
    return sigma * a_x / math.hypot(a_x, a_n) * max(abs(wheel_speed), p.tyre_reference_speed)


def side_slip_from_accelerations(v_t: float, wheel_speed: float, a_t: float, a_n: float, p: MixingParameters):
    """Side-slip velocity of the tyres that carry the force the accelerometers measure (a quasi-static
    tyre, no relaxation length): the lateral part of the combined slip, tan(alpha) = sigma a_n / |a|
    (combined_slip of tyre_force_per_mass(v_t, a_t, a_n)), v_n = -v_ref tan(alpha) with the slip's
    reference speed v_ref = max(|v_t|, |wheel_speed|, tyre_reference_speed), as the tyre curve was
    identified.

    In the linear range and a pure turn tan(alpha) = -a_n / K_alpha, as lateral_velocity_model at
    a_n = v_t omega; braking or driving takes friction from the turn and the same a_n needs more slip.

    Returns:
        (v_n, |a| / a_peak): the slip and the tyres' utilisation (uncapped; 0, 0 for a_peak = inf).
    """
    a_x, a_n = tyre_force_per_mass(v_t, a_t, a_n, p)
    sigma, utilisation = combined_slip(a_x, a_n, p)
    if utilisation == 0.0:
        return 0.0, 0.0
    reference = max(abs(v_t), abs(wheel_speed), p.tyre_reference_speed)
    return -reference * sigma * a_n / math.hypot(a_x, a_n), utilisation


def inertial_relaxation(utilisation: float, p: MixingParameters) -> float:
    """q_I = 1 - (1 - q2_inertial) sqrt(1 - u^2) of S(17)'s inertial branch (mix), u capped at 1."""
    return 1.0 - (1.0 - p.q2_inertial) * math.sqrt(1.0 - min(utilisation, 1.0) ** 2)


def mixing_utilisation(v_t: float, omega: float, a_t: float, a_n: float, p: MixingParameters) -> float:
    """The tyres' utilisation u that sets q_I in mix, from the mixed v_t, omega and ^I a_t, ^I a_n:
    |a| / a_peak of tyre_force_per_mass (side_slip_from_accelerations), else tyre_utilisation."""
    if not p.side_slip_from_accelerations:
        return tyre_utilisation(v_t, omega, p)
    if math.isinf(p.tyre_peak_acceleration):
        return 0.0
    a_x, a_n = tyre_force_per_mass(v_t, a_t, a_n, p)
    return math.hypot(a_x, a_n) / p.tyre_peak_acceleration


def wheels_at_rest(odo) -> bool:
    """Neither wheel turned this sample: the odometric v_t and omega are both exactly 0."""
    return odo[0] == 0.0 and odo[1] == 0.0


def accelerometer_pair_disagreement(accelerometers, omega: float, position) -> float:
    """|a_t1 - a_t2 - (-2 omega^2 x)|: how far the two accelerometers' t axes (S(3): at +-(x, y))
    disagree beyond their centripetal difference (health.accelerometer_pair.pair_rotational_difference; the
    angular-acceleration term -2 omega_dot y is left in: it is part of what the tolerance allows). NaN if
    a reading is not finite."""
    return abs(accelerometers[0] - accelerometers[2] - pair_rotational_difference(omega, position)[0])


SLIDE_ONSET_INITIAL = (0, -10, math.nan)
"""slide_onset_step's initial state: released, armed after 10 samples (one Tinyphoon T_C)."""


def slide_onset_step(
    state,
    odo_v_t: float,
    inertial_v_t: float,
    inertial_a_t: float,
    disagreement: float,
    p: MixingParameters,
    T_N: float,
):
    """The per-sample wheel-speed test that hands S(15)'s v_t to the inertial estimate at a slide's onset
    (an extension of S(11)-(12): C1 follows S(11)'s batch of T_C, which sees a lock only at the batch's
    end and falls over three batches, 60 ms in which the mixed v_t follows the locked wheels).

    The test sets when the odometric v_t changes in one sample by more than slide_onset_jump beyond
    ^I a_t T_N (no body accelerates at that rate: the wheels left it); it holds while the odometric and
    the inertial v_t disagree, and releases after slide_onset_release_samples samples of agreement within
    slide_onset_release, after slide_onset_max_time, or at once while the accelerometers disagree with
    each other by slide_onset_pair_tolerance or more (``disagreement``,
    accelerometer_pair_disagreement; NaN counts as disagreeing). A non-finite odometric v_t (an encoder
    the sensor checks could not replace) neither sets it nor counts as agreement (the hold ages on), and
    the next finite one is not tested against it.

    Args:
        state: (count, age, previous odometric v_t): count 0 released, else 1 + samples of agreement
            so far; age the samples since it set, or, negative while released, the samples until the
            test arms (SLIDE_ONSET_INITIAL: the odometry's first speeds span an unknown previous angle,
            and the EKF's v_t reaches the odometry's through C1 within one T_C).

    Returns:
        (next state, True while set: C1 = 0 in S(15) for this sample)
    """
    count, age, previous = state
    if count == 0 and age < 0:  # arming
        return (0, age + 1, odo_v_t), False
    if not disagreement < p.slide_onset_pair_tolerance:
        return (0, 0, odo_v_t), False
    if not math.isfinite(odo_v_t):  # the hold ages on; the next finite speed has no previous one
        if count == 0:
            return (0, 0, math.nan), False
        age += 1
        if age * T_N > p.slide_onset_max_time:
            return (0, 0, math.nan), False
        return (count, age, math.nan), True
    if count == 0:
        if abs(odo_v_t - previous - inertial_a_t * T_N) > p.slide_onset_jump:  # False for NaN previous
            count, age = 1, 0
        else:
            return (0, 0, odo_v_t), False
    if abs(odo_v_t - inertial_v_t) < p.slide_onset_release:
        count = 0 if count >= p.slide_onset_release_samples else count + 1
    else:
        count = 1
    age += 1
    if age * T_N > p.slide_onset_max_time:
        count = 0
    return (count, age if count else 0, odo_v_t), count > 0


def push_taken(external_force: bool, inertial_fault: bool) -> bool:
    """Does S(17) take the perturbation monitor's sideways push (``external_force``) this sample? Not
    while an inertial channel is excluded: the sensor checks replace it, and a replacement carries no
    kinematics of its own (mix_checked; mixing_gain's w_n follows)."""
    return bool(external_force) and not inertial_fault


def mixing_gain(
    mixed,
    c1: float,
    c2: float,
    p: MixingParameters,
    check: float = 0.0,
    external_force: bool = False,
    standing: bool = False,
) -> np.ndarray:
    """[w_t, w_n]: how much the mixed estimate ``mixed`` (mix's output) took from outside the EKF.

    S(15): w_t = C1, the weight of odometry in v_t. S(17): v_n = C2 q2 v_n,k-1 + (1 - C2) q_I ^I v_n +
    (the tyre model's terms); with v_n,k-1 = ^I v_n to first order in T_N, w_n = 1 - C2 q2 - (1 - C2) q_I
    is the weight of the tyre model (the paper's S(17): w_n = C2 (1 - q2), relaxation towards zero).
    ``check``, the weight w of the free integral in the inertial branch (tyre_model_check), takes its
    share from the tyre model: the branch's outside weight is (1 - q_I)(1 - w) (the free integral is the
    EKF's own kinematics, no measurement).
    While the robot stands (``standing``: the zero-velocity update, systems/standstill.py) both
    velocities are measured as zero: [1, 1].
    While an outside force pushes the body (``external_force``, mix_checked) v_n is the free integral
    alone: w_n = 0.
    The EKF's covariance takes the mixing as updates with these gains (ekf.ekf_mixing_covariance).
    """
    if standing:
        return np.array([1.0, 1.0])
    if external_force:
        return np.array([c1, 0.0])
    utilisation = mixing_utilisation(mixed[0], mixed[2], mixed[3], mixed[4], p)
    q_inertial = inertial_relaxation(utilisation, p)
    if check > 0.0:
        q_inertial = 1.0 - (1.0 - q_inertial) * (1.0 - check)
    w_n = 1.0 - c2 * p.q2 - (1.0 - c2) * q_inertial
    return np.array([c1, w_n])


def tyre_model_check(free_v_n: float, curve_v_n: float, reference_speed: float, p: MixingParameters) -> float:
    """The weight w of the free integral of the lateral kinematics in S(17)'s inertial branch, from their
    disagreement d = |free_v_n - curve_v_n| / v_ref in deg (curve_v_n: the tyre curve's own side slip,
    v_ref the slip's reference speed): l(d) = logsig(-steepness, d, tyre_model_gate_deg), rescaled to
    vanish below GATE_DEAD_ZONE deg under the gate, (l(d) - l_0) / (1 - l_0) >= 0, so that a robot whose
    floor matches the curve runs exactly as without the check. 0 for tyre_model_gate_deg = inf, without a
    tyre curve (tyre_peak_acceleration = inf) and for a reference speed of 0."""
    if math.isinf(p.tyre_model_gate_deg) or math.isinf(p.tyre_peak_acceleration) or not reference_speed > 0.0:
        return 0.0  # no check, no tyre curve to check, or no speed to refer the side slip to
    disagreement = math.degrees(abs(free_v_n - curve_v_n) / reference_speed)
    floor = p.tyre_model_gate_deg - GATE_DEAD_ZONE
    if not disagreement > floor:
        return 0.0
    l0 = logsig(-p.tyre_model_gate_steepness, floor, p.tyre_model_gate_deg)
    return (logsig(-p.tyre_model_gate_steepness, disagreement, p.tyre_model_gate_deg) - l0) / (1.0 - l0)


GATE_DEAD_ZONE = 1.0
"""deg below tyre_model_gate_deg where tyre_model_check's weight is exactly 0 (logsig there: 5 %)."""


def free_side_slip_step(
    predicted: float, curve: float, v_n: float, utilisation: float, p: MixingParameters, T_N: float
) -> tuple[float, float]:
    """The tyre-model check's state (F, S) after sample k. ``predicted``: the free integral of the
    lateral kinematics carried to this sample (the previous one plus the EKF's v_n increment
    ^I v_n - v_n,k-1, i.e. the integral of a_n - omega v_t); ``curve``: the tyre curve's own side slip.
    While the tyres' lateral ``utilisation`` |a_n| / a_peak is below free_side_slip_anchor both are
    anchored to the mixed ``v_n``; else F relaxes towards it with free_side_slip_time_constant (which
    bounds the integral's drift) and S is ``curve``."""
    if utilisation < p.free_side_slip_anchor:
        return v_n, v_n
    return predicted + (T_N / p.free_side_slip_time_constant) * (v_n - predicted), curve


def peak_slip(p: MixingParameters) -> float:
    """The slip sigma_peak = tan(pi / (2 C)) / B at which the tyre curve a_peak sin(C atan(B sigma))
    peaks (Tinyphoon: 0.175, Kurt3D 0.219)."""
    return math.tan(0.5 * math.pi / p.tyre_shape_factor) / p.tyre_stiffness_factor


_BELIEVED = [None, math.nan, None]
"""believed_tyre's last (p, a_peak, result): mix_checked and mixing_gain ask for the same one."""


def believed_tyre(p: MixingParameters, a_peak: float) -> MixingParameters:
    """``p`` with the identified tyre peak ``a_peak`` (tyre_peak_step); ``p`` itself while it is unchanged.
    A copy without __post_init__'s checks (24 us): tyre_peak_step keeps a_peak within its valid range."""
    if a_peak == p.tyre_peak_acceleration:
        return p
    if _BELIEVED[0] is p and _BELIEVED[1] == a_peak:
        return _BELIEVED[2]
    believed = copy.copy(p)
    believed.tyre_peak_acceleration = a_peak
    _BELIEVED[:] = [p, a_peak, believed]
    return believed


def tyre_peak_step(
    state,
    wheel_speed: float,
    v_t: float,
    free_v_n: float,
    a_t: float,
    a_n: float,
    learn: bool,
    p: MixingParameters,
    T_N: float,
):
    """Online identification of the tyres' peak force per unit mass a_peak = mu g f_w (issue 15: the
    floor's grip is not the data sheet's), the a_peak the tyre curve of S(15) and S(17) uses from the
    next sample on.

    Two pieces of evidence, both from the navigation's own sensors:

    - a lower bound: the tyres carried the force per unit mass |a| that the EKF's accelerations give
      (tyre_force_per_mass), so a_peak is at least its PT1 over tyre_peak_force_time_constant, held
      with the decay time tyre_peak_hold_time;
    - the force while the tyres slip near or past their peak: the curve a_peak sin(C atan(B sigma))
      inverted at the combined slip sigma = hypot(kappa, tan alpha), a_peak = |a| / sin(C atan(B sigma)).
      kappa = (wheel_speed - v_t) / v_ref is the wheels' slip against the mixed v_t, tan alpha =
      free_v_n / v_ref the free integral of the lateral kinematics (free_side_slip_step), v_ref =
      max(|v_t|, |wheel_speed|, tyre_model_gate_speed). kappa is evidence once C1 hands v_t to the
      accelerometers (a lock, a spin); at C1 = 1 it is the believed curve's own creep (S(15)) and pulls
      towards the belief. F is free of the curve while the tyres carry lateral force (anchored to the
      estimate below free_side_slip_anchor). Near the peak the read hardly depends on sigma: from
      tyre_peak_evidence_slip x sigma_peak (peak_slip) on a sample weighs in, fully from
      tyre_peak_full_evidence_slip x sigma_peak; a_peak follows the reads, each limited to a factor
      1 + tyre_peak_candidate_bound of a_peak, with tyre_peak_identification_time_constant at full
      weight.

    The estimate stays within [tyre_peak_min_ratio, tyre_peak_max_ratio] x the nominal a_peak. Nothing
    is learnt from a non-finite sample or while ``learn`` is False: mix_checked passes False while a
    sensor check excludes a channel or the wheels are at rest (wheels_at_rest: a standstill, where the
    force is the accelerometers' bias, or both wheels locked).
    The drag is taken at the wheels' speed, as S(15)'s creep takes it (at the body's speed v_t the
    matched square's braking locks read 4 % low instead of 3 %, and the built-ins' matched errors grew
    on 3 seeds).

    Args:
        state: (a_peak, PT1 of |a|, its held value) after the previous sample (initial: nominal, 0, 0).
        p: the nominal MixingParameters (its tyre_peak_acceleration is the nominal a_peak).

    Returns:
        the state after this sample.
    """
    a_peak, force_filtered, held = state
    if not learn or not p.tyre_peak_identification or math.isinf(p.tyre_peak_acceleration):
        return state
    a_x, a_y = tyre_force_per_mass(wheel_speed, a_t, a_n, p)  # as S(15)'s creep (longitudinal_slip_speed)
    force = math.hypot(a_x, a_y)
    reference = max(abs(v_t), abs(wheel_speed), p.tyre_model_gate_speed)
    slip = math.hypot((wheel_speed - v_t) / reference, free_v_n / reference)
    if not (math.isfinite(force) and math.isfinite(slip)):
        return state
    force_filtered = pt1_step(force_filtered, force, p.tyre_peak_force_time_constant, T_N)
    held = max(force_filtered, held * math.exp(-T_N / p.tyre_peak_hold_time))
    evidence = (slip / peak_slip(p) - p.tyre_peak_evidence_slip) / (
        p.tyre_peak_full_evidence_slip - p.tyre_peak_evidence_slip
    )
    if evidence > 0.0:
        share = math.sin(p.tyre_shape_factor * math.atan(p.tyre_stiffness_factor * slip))
        gain = min(evidence, 1.0) * min(T_N / p.tyre_peak_identification_time_constant, 1.0)
        bound = p.tyre_peak_candidate_bound  # robust: a stale slip (the slide ending) moves it little
        candidate = min(max(force / share, a_peak / (1.0 + bound)), a_peak * (1.0 + bound))
        a_peak += gain * (candidate - a_peak)
    nominal = p.tyre_peak_acceleration
    a_peak = min(max(a_peak, held, p.tyre_peak_min_ratio * nominal), p.tyre_peak_max_ratio * nominal)
    return a_peak, force_filtered, held


def mix_checked(
    odo,
    inertial,
    c1: float,
    c2: float,
    c3: float,
    previous,
    p: MixingParameters,
    check_state,
    T_N: float,
    inertial_fault: bool = False,
    encoder_fault: bool = False,
    external_force: bool = False,
):
    """mix with the tyre-model check: (mixed estimate, w, check state after this sample).

    ``check_state``: (F, S, a_peak, |a| PT1, held) after sample k-1, or (F, S) for the nominal
    a_peak throughout (None: no check, w = 0, as mix). The tyre curve is the one at the identified
    a_peak (tyre_peak_step updates the last three; it learns nothing while ``inertial_fault`` or
    ``encoder_fault``). F the free integral of
    the lateral kinematics (free_side_slip_step), S the side slip the tyre curve alone would give (S(17)
    as in mix, run on its own). Both are carried to this sample by the EKF's increment ^I v_n - v_n,k-1;
    w = tyre_model_check(F, S, v_ref), and S(17)'s inertial branch relaxes towards (1 - w) f + w F
    instead of the curve's f. While the tyres' lateral utilisation |^I a_n| / a_peak is below
    free_side_slip_anchor both restart from the mixed v_n (a braking lock uses the tyres to the full,
    but not sideways), and so they do while an inertial channel is excluded (``inertial_fault``: the
    sensor checks replace it; a replacement is no evidence against the curve, w = 0).

    ``external_force``: an outside force pushes the body sideways (the perturbation monitor's sideways
    push). The accelerometers then measure the push with the tyres' forces, so neither the steady-turn
    model nor the curve at the measured forces holds, and a push the tyres hold reads |a_n| ~ 0, where F
    would be anchored to an estimate that had dropped the side slip the push built up. While it holds
    (and no inertial channel is excluded) v_n is F alone (w = 1, in both of S(17)'s branches), F is
    neither anchored nor relaxed, and the tyre peak learns nothing."""
    nominal = p
    identify = check_state is not None and len(check_state) == 5
    if identify:
        p = believed_tyre(p, check_state[2])
    # Wheels that did not turn this sample do not creep: their tyres hold the force (at a standstill
    # only the accelerometers' bias) by static friction.
    at_rest = wheels_at_rest(odo)
    rolling = 0.0 if at_rest else odo[0] - longitudinal_slip_speed(odo[0], inertial[3], inertial[4], p)
    v_t = c1 * rolling + (1.0 - c1) * inertial[0]
    omega = c3 * odo[1] + (1.0 - c3) * inertial[2]
    model = lateral_velocity_model(v_t, omega, p)
    model_prev = lateral_velocity_model(previous[0], previous[2], p)
    if p.side_slip_from_accelerations:
        target, utilisation = side_slip_from_accelerations(v_t, odo[0], inertial[3], inertial[4], p)
    else:
        target, utilisation = model, tyre_utilisation(v_t, omega, p)
    q_inertial = inertial_relaxation(utilisation, p)

    def side_slip(carried, relaxed_from, towards):
        return (
            c2 * (model + p.q2 * (relaxed_from - model_prev))
            + (1.0 - c2) * (towards + q_inertial * (carried - towards))
        )

    check = 0.0
    pushed = check_state is not None and push_taken(external_force, inertial_fault)
    if check_state is not None and not inertial_fault:
        increment = inertial[1] - previous[1]
        free, curve = (
            check_state[0] + increment,
            side_slip(check_state[1] + increment, check_state[1], target),
        )
        check = 1.0 if pushed else tyre_model_check(free, curve, max(abs(v_t), p.tyre_model_gate_speed), p)
        if check > 0.0:
            target = target + check * (free - target)
    v_n = free if pushed else side_slip(inertial[1], previous[1], target)
    next_state = None
    if check_state is not None:
        lateral = abs(inertial[4]) / p.tyre_peak_acceleration
        if inertial_fault:
            next_state = (v_n, v_n)
        elif pushed:  # neither anchored nor relaxed: the kinematics are all there is
            next_state = (free, curve)
        else:
            next_state = free_side_slip_step(free, curve, v_n, lateral, p, T_N)
    if identify:
        peak = tyre_peak_step(
            check_state[2:5],
            odo[0],
            v_t,
            next_state[0] if inertial_fault else free,
            inertial[3],
            inertial[4],
            not (inertial_fault or encoder_fault or at_rest or pushed),
            nominal,
            T_N,
        )
        next_state = (*next_state, *peak)
    return np.array([v_t, v_n, omega, inertial[3], inertial[4]]), check, next_state


def mix(odo, inertial, c1: float, c2: float, c3: float, previous, p: MixingParameters) -> np.ndarray:
    """S(15)-(17): the mixed estimate [v_t, v_n, omega, ^I a_t, ^I a_n] (without the tyre-model check:
    mix_checked).

    v_t = C1 (^O v_t - s) + (1 - C1) ^I v_t, s = longitudinal_slip_speed(^O v_t, ^I a_t, ^I a_n) (0 in the
    paper's S(15), and while neither wheel turned this sample: a tyre at rest creeps not, whatever the
    biased accelerometers say; 0.1 mm/s of v_t, 0.4 m an hour at a standstill otherwise);
    omega = C3 ^O omega + (1 - C3) ^I omega;
    v_n = C2 [m_k + q2 (v_n,k-1 - m_k-1)] + (1 - C2) [f_k + q_I (^I v_n - f_k)]: below the a_n threshold v_n
    follows the steady-turn model m = lateral_velocity_model(v_t, omega) and relaxes towards it by q2;
    above it the inertial v_n relaxes towards f = side_slip_from_accelerations(v_t, ^O v_t, ^I a_t, ^I a_n)
    (m with side_slip_from_accelerations = False) by q_I = 1 - (1 - q2_inertial) sqrt(1 - u^2), u the
    tyres' utilisation capped at 1. The paper's S(17) for a_peak = inf (m = f = 0) and q2_inertial = 1.
    At a standstill the zero-velocity update (systems/standstill.py) replaces the whole estimate.

    Args:
        previous: the previous mixed estimate x_k-1 (the EKF state), for v_n,k-1 and m_k-1.
    """
    return mix_checked(odo, inertial, c1, c2, c3, previous, p, None, 0.0)[0]


class MixerC1(LeafSystem):
    """Mixing parameter C1 S(12): double-sided logsig of the slip detector's dv (or of its leaky sum over
    the recent batches, accumulate_delta_v, when larger), PT1-relaxed, every T_C.

    .. pydrake_system::

        name: MixerC1
        input_ports:
        - delta_v
        output_ports:
        - C1
        - delta_v_held
        - delta_v_accumulated

    - delta_v: dv_K from the TangentialSlipDetector, sampled at t = K*T_C; NaN (a batch with no usable
      sample) holds C1 and A_K (mixer_c1_step).
    - C1: C1_K (state); computed at t_K and used by the velocity mixer from the next sample on.
    - delta_v_held: dv_K as sampled (state), for logging.
    - delta_v_accumulated: A_K = dv_memory A_K-1 + dv_K (state).

    Args:
        params: MixingParameters. T_C: control period (s). c1_initial: C1_-1 (1 = trust odometry).
    """

    def __init__(self, params: MixingParameters, T_C: float, c1_initial: float = 1.0):
        super().__init__()
        self._p = params
        self._dv = self.DeclareVectorInputPort("delta_v", 1)
        self._c1 = self.DeclareDiscreteState([c1_initial])
        self._dv_held = self.DeclareDiscreteState(1)
        self._dv_sum = self.DeclareDiscreteState(1)
        self.DeclareStateOutputPort("C1", self._c1)
        self.DeclareStateOutputPort("delta_v_held", self._dv_held)
        self.DeclareStateOutputPort("delta_v_accumulated", self._dv_sum)
        self.DeclarePeriodicDiscreteUpdateEvent(T_C, 0.0, self._update)

    def _update(self, context, discrete_state):
        dv = self._dv.Eval(context)[0]
        c1 = context.get_discrete_state(self._c1).get_value()[0]
        dv_sum = context.get_discrete_state(self._dv_sum).get_value()[0]
        c1, dv_sum = mixer_c1_step(c1, dv_sum, dv, self._p)
        discrete_state.set_value(self._c1, [c1])
        discrete_state.set_value(self._dv_held, [dv])
        discrete_state.set_value(self._dv_sum, [dv_sum])


C2C3_STEP_LAYOUT = (("C2_C3", 2), ("C3_filters", 2))
"""MixerC2C3's ``step`` output, in order: (name, size); diagrams/split.py slices it."""
MIXER_LAYOUT = (
    ("mixed_estimate", 5),
    ("body_velocity", 3),
    ("mixing_gain", 2),
    ("tyre_model_check", 6),
    ("slide_onset", 1),
    ("slide_onset_state", 3),
)
"""VelocityMixer's ``mixing`` output, in order: (name, size); diagrams/split.py slices it."""
MIXER_START = {name: sum(size for _, size in MIXER_LAYOUT[:i]) for i, (name, _) in enumerate(MIXER_LAYOUT)}
"""The index of each MIXER_LAYOUT entry's first element in the ``mixing`` output."""
_CHECK_STATE = slice(MIXER_START["tyre_model_check"] + 1, MIXER_START["slide_onset"])
"""The tyre-model check's state [F_k, S_k, a_peak, |a| PT1, held] in the mixing output (after w)."""
TYRE_MODEL_STATE_LAYOUT = (("free_and_curve_v_n", 2), ("tyre_peak", 1), ("peak_bound", 2))
"""VelocityMixer's ``tyre_model_state`` output, in order: (name, size): F and S, a_peak, the lower
bound's filter and held value."""
_ONSET_STATE = slice(MIXER_START["slide_onset_state"], MIXER_START["slide_onset_state"] + 3)


class MixerC2C3(LeafSystem):
    """Mixing parameters C2 S(13) (lateral acceleration) and C3 S(14) (yaw-rate disagreement), at T_N.

    .. pydrake_system::

        name: MixerC2C3
        input_ports:
        - inertial_estimate
        - odometry
        output_ports:
        - step

    - step (direct feedthrough), in C2C3_STEP_LAYOUT's order: C2_C3, [C2, C3] of this sample's EKF
      estimate and odometry (C3 of the filters below); C3_filters, [^O omega - ^I omega, ^I omega], each
      PT1-filtered up to this sample (c3_residual, c3_turn_rate). One vector, one Python call per sample;
      the navigation diagram slices it with a Demultiplexer (diagrams/split.py).

    Update every T_N: the filters (state).

    Args:
        params: MixingParameters. T_N: navigation period (s).
    """

    def __init__(self, params: MixingParameters, T_N: float):
        super().__init__()
        self._p, self._T_N = params, T_N
        self._inertial = self.DeclareVectorInputPort("inertial_estimate", 5)
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._filters = self.DeclareDiscreteState(2)
        prereq = {self.xd_ticket(), self._inertial.ticket(), self._odo.ticket()}
        self._step = self.DeclareVectorOutputPort("step", 4, self._calc, prerequisites_of_calc=prereq)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc(self, context, output):
        previous_residual, previous_turn = context.get_discrete_state(self._filters).get_value().tolist()
        inertial = self._inertial.Eval(context).tolist()
        omega_o = float(self._odo.Eval(context)[1])
        residual = c3_residual(previous_residual, omega_o, inertial[2], self._p, self._T_N)
        turn = c3_turn_rate(previous_turn, inertial[2], self._p, self._T_N)
        c3 = mixing_c3(residual, self._p, turn)
        output.SetFromVector([mixing_c2(inertial[4], self._p), c3, residual, turn])

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._filters, self._step.Eval(context)[2:4])


class VelocityMixer(LeafSystem):
    """Velocity mixer S(15)-(17) with the tyre-model check (mix_checked) and the per-sample slide-onset
    test (slide_onset_step: while it holds, S(15) takes C1 = 0); its output is the navigation estimate
    and the EKF's next state.

    .. pydrake_system::

        name: VelocityMixer
        input_ports:
        - odometry
        - inertial_estimate
        - C1
        - C2_C3
        - previous_estimate
        - inertial_fault
        - accelerometers
        - encoder_fault
        - external_force
        - standstill
        output_ports:
        - mixing
        - tyre_model_state

    - previous_estimate: the EKF state x_k-1 (the previous mixed estimate), for v_n,k-1 and the tyre
      model's previous value in S(17).
    - inertial_fault: 1 while the sensor checks exclude an inertial channel (the check rests, mix_checked).
    - encoder_fault: 1 while they exclude an encoder (the tyre peak learns nothing, tyre_peak_step).
    - external_force (optional): 1 while the perturbation monitor flags a sideways push on the body
      (perturbation_monitor.sideways_push): v_n is the free integral of the lateral kinematics
      (mix_checked); unconnected: 0.
    - standstill (optional): 1 while the robot stands (systems/standstill.py): the mixed estimate is
      zero and the check's F and S restart from rest (zero_velocity_update), applied to mix_checked's
      output, with the gain [1, 1] (mixing_gain); unconnected: 0.
    - accelerometers: the checked (and corrected) [a_t1, a_n1, a_t2, a_n2] the EKF reads: the slide-onset
      test trusts the inertial v_t only while the pair agrees (accelerometer_pair_disagreement, with
      ^I omega).
    - mixing (direct feedthrough), in MIXER_LAYOUT's order: mixed_estimate [v_t, v_n, omega, ^I a_t,
      ^I a_n]; body_velocity [v_t, v_n, omega] for pose integration and the side-slip angle; mixing_gain
      [C1, w_n] (mixing_gain; C1 = 0 while the slide-onset test holds), the weights of odometry and the
      tyre model, for the EKF's P; tyre_model_check [w, F_k, S_k, a_peak, |a| PT1, held], the free
      integral's weight (tyre_model_check), the free integral and the tyre curve's own side slip after
      this sample (mix_checked), the identified tyre peak and its lower bound's filter and held value
      (tyre_peak_step); slide_onset, 1 while the test holds; slide_onset_state, the test's state after
      this sample. One vector, one Python call per sample; the navigation diagram slices it with a
      Demultiplexer (diagrams/split.py).
    - tyre_model_state: the state [F, S, a_peak, |a| PT1, held] (the sensor checks read a_peak).

    Update every T_N: F, S, a_peak with its filter and held value, and the slide-onset test's state
    (state, from SLIDE_ONSET_INITIAL).

    Args:
        params: MixingParameters. T_N: navigation period (s). initial_v_n: F_-1 = S_-1, the initial
            estimate's v_n (m/s). accelerometer_position: accelerometer 1's nominal (x, y) (m; S(3)).
    """

    def __init__(
        self,
        params: MixingParameters,
        T_N: float,
        initial_v_n: float,
        accelerometer_position,
    ):
        super().__init__()
        self._p, self._T_N = params, T_N
        self._position = (float(accelerometer_position[0]), float(accelerometer_position[1]))
        self._odo = self.DeclareVectorInputPort("odometry", 4)
        self._inertial = self.DeclareVectorInputPort("inertial_estimate", 5)
        self._c1 = self.DeclareVectorInputPort("C1", 1)
        self._c23 = self.DeclareVectorInputPort("C2_C3", 2)
        self._prev = self.DeclareVectorInputPort("previous_estimate", 5)
        self._fault = self.DeclareVectorInputPort("inertial_fault", 1)
        self._acc = self.DeclareVectorInputPort("accelerometers", 4)
        self._enc_fault = self.DeclareVectorInputPort("encoder_fault", 1)
        self._external = self.DeclareVectorInputPort("external_force", 1)
        self._standstill = self.DeclareVectorInputPort("standstill", 1)
        initial = [initial_v_n, initial_v_n, params.tyre_peak_acceleration, 0.0, 0.0]
        self._check = self.DeclareDiscreteState(initial)
        self._onset_state = self.DeclareDiscreteState([float(v) for v in SLIDE_ONSET_INITIAL])
        self.DeclareStateOutputPort("tyre_model_state", self._check)
        self._mixing = self.DeclareVectorOutputPort(
            "mixing", sum(size for _, size in MIXER_LAYOUT), self._calc
        )
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc(self, context, output):
        c2, c3 = self._c23.Eval(context).tolist()
        odo = self._odo.Eval(context).tolist()
        inertial = self._inertial.Eval(context).tolist()
        count, age, previous = context.get_discrete_state(self._onset_state).get_value().tolist()
        disagreement = accelerometer_pair_disagreement(
            self._acc.Eval(context).tolist(), inertial[2], self._position
        )
        onset_state, onset = slide_onset_step(
            (int(count), int(age), previous),
            odo[0],
            inertial[0],
            inertial[3],
            disagreement,
            self._p,
            self._T_N,
        )
        c1 = 0.0 if onset else float(self._c1.Eval(context)[0])
        check_state = context.get_discrete_state(self._check).get_value().tolist()
        fault = self._fault.Eval(context)[0] > 0.5
        pushed = push_taken(self._external.HasValue(context) and self._external.Eval(context)[0] > 0.5, fault)
        mixed, check, state = mix_checked(
            odo,
            inertial,
            c1,
            c2,
            c3,
            self._prev.Eval(context).tolist(),
            self._p,
            check_state,
            self._T_N,
            fault,
            self._enc_fault.Eval(context)[0] > 0.5,
            pushed,
        )
        standing = self._standstill.HasValue(context) and self._standstill.Eval(context)[0] > 0.5
        if standing:
            mixed, state = zero_velocity_update(mixed, state)
        tyre = believed_tyre(self._p, check_state[2])
        gain = mixing_gain(mixed, c1, c2, tyre, check, pushed, standing)
        output.SetFromVector(
            [
                *mixed.tolist(),
                *mixed[0:3].tolist(),
                *gain,
                check,
                *state,
                1.0 if onset else 0.0,
                *onset_state,
            ]
        )

    def _update(self, context, discrete_state):
        mixing = self._mixing.Eval(context)
        discrete_state.set_value(self._check, mixing[_CHECK_STATE])
        discrete_state.set_value(self._onset_state, mixing[_ONSET_STATE])
