"""The tuning of the mixing of odometric and inertial estimates (Seyr & Jakubek §IV-D,
systems/navigation/mixing/mixer.py) and its range checks."""

import dataclasses as dc
import math

from slipnav.systems.ranges import out_of_range, require_flag, require_in, require_integer


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
            square's gradual locks within one T_C (docs/results.md, section paper-effects, row dv_memory),
            short enough that the inertial v_t taken meanwhile hardly drifts (accelerometer bias sums to
            3.3 x its ~0.4 mm/s per batch, far below b1). 0: the paper's S(12).
        delta_v_running_integral: S(11)'s acceleration term is the running integral of the mean
            tangential acceleration since the batch start ("discrete integration", §IV-C;
            systems/navigation/slip_detector.py). False: the printed single-sample term (a_t1,k + a_t2,k)
            T_N/2.
        a2: C2 steepness (s^2/m): 4 gives a 10 %-90 % transition over 1.1 m/s^2.
        b2: C2 threshold on |a_n| (m/s^2): above the EKF's a_n noise (commotion) at speed.
        a3: C3 steepness (s/rad): 200 gives a 10 %-90 % transition over 0.022 rad/s.
        b3: C3 threshold on |^O omega - ^I omega| (rad/s), after the PT1 below: 0.02. The single-sample
            odometric yaw rate is quantised in steps of 0.11 rad/s (7.7 mm/s / 68 mm); filtered over one
            T_C its error is < 0.011 rad/s and the gyro's noise 0.003 rad/s, while the felt shoes' 1-2 %
            scrub in a 3 rad/s spot turn gives 0.03-0.06 rad/s: with the gyro's bias estimated
            (systems/navigation/yaw_calibration.py) the turn is the gyro's.
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
            as possible but large enough for consistent velocity (0.99: a time constant of 0.2 s).
        q2_inertial: the same for the inertial v_n, weighted 1 - C2 (|a_n| > b2), at zero tyre force;
            the pull fades with the tyre curve's slope factor sqrt(1 - (|a|/a_peak)^2) to nothing at the
            friction limit, where any slip angle past the peak gives about the same force. Below 1 so that
            the side slip of a hard turn is held to the tyre curve rather than integrated with the
            accelerometers' commotion and bias (0.3 m/s^2 rms at 1.6 m/s: ~0.03 m/s, 1 deg, over a 0.5 s
            turn); close to 1 because the tyre curve is quasi-static (0.95: a time constant of 40 ms at
            small |a|). 1: the paper's S(17).
        side_slip_from_accelerations: the inertial branch's pull targets the side slip at the tyre force
            the accelerometers measure (side_slip_from_accelerations), rather than the steady-turn slip at
            v_t omega (lateral_velocity_model). The force follows the slip angle, not v_t omega: it lags
            v_t omega while the slip builds up, overshoots while it decays, and drops when the tyres
            brake or drive (the friction circle), which v_t omega cannot know (docs/results.md, section
            error-budget, row "S(17) pulled to the steady-turn slip"). False: the steady-turn slip.
        tyre_peak_acceleration: the tyres' largest lateral acceleration mu g f_w (m/s^2), identified with
            the two shape factors below from steady turns. Default: Tinyphoon, 0.7 * 9.81 * 0.8 = 5.49.
            inf: no side slip (the paper's S(17) relaxes v_n to zero).
        tyre_stiffness_factor: Pacejka B of the lateral tyre curve (1/rad). Default: Tinyphoon, 15.
        tyre_shape_factor: Pacejka C, in (1, 2). Default: Tinyphoon, 1.3.
        odometry_slip_compensation: take the tyres' steady longitudinal slip off ^O v_t in S(15)
            (longitudinal_slip_speed). Rubber tyres creep ahead of the body whenever they push: 1.5 % at
            1.6 m/s^2, 0.04 m/s at the end of the corner's launch, 0.08 m/s in its sliding turn, which the
            odometric v_t otherwise carries as a speed error (docs/results.md, section error-budget, row
            "paper's S(15): odometric v_t with the creep"). False: the paper's S(15).
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
            deg; on the matched robot it stays within 1.5 deg (its drift). 2.5: between the two, so that
            the floor's slide hands the inertial branch to the integral while the matched robot keeps the
            curve. inf: the curve alone.
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
            (6.5 of its 7.7 mm/s encoder quanta per sample; docs/navigation.md, A slide's onset: why it is
            off by default); at least 3 quanta (check_slide_onset).
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
        self._check_mixing_laws()
        self._check_tyre_curve()
        self._check_slide_onset_and_tyre_peak()

    def _check_mixing_laws(self):
        """The ranges of S(12)-(14) and S(17)'s relaxations."""
        for name in ("a1", "b1", "a2", "b2", "a3", "b3", "tyre_stiffness_factor"):
            require_in(f"mixing.{name}", getattr(self, name), "(0, inf)")
        for name, allowed in (("p", "[0, 1)"), ("q2", "(0, 1)"), ("dv_memory", "[0, 1)")):
            require_in(f"mixing.{name}", getattr(self, name), allowed)
        require_in("mixing.c3_residual_time_constant", self.c3_residual_time_constant, "[0, inf) s")
        require_in("mixing.gyro_turn_rate", self.gyro_turn_rate, "[0, inf] rad/s")  # inf: S(14) alone
        require_in("mixing.q2_inertial", self.q2_inertial, "(0, 1]")

    def _check_tyre_curve(self):
        """The ranges of the tyre curve, its check and the switches."""
        # inf: no side slip, the paper's S(17)
        require_in("mixing.tyre_peak_acceleration", self.tyre_peak_acceleration, "(0, inf] m/s^2")
        require_in("mixing.tyre_shape_factor", self.tyre_shape_factor, "(1, 2)")
        for name in (
            "odometry_slip_compensation",
            "side_slip_from_accelerations",
            "delta_v_running_integral",
            "tyre_peak_identification",
        ):
            require_flag(f"mixing.{name}", getattr(self, name))
        require_in("mixing.tyre_model_gate_deg", self.tyre_model_gate_deg, "(0, inf] deg")  # inf: the curve
        for name in (
            "tyre_model_gate_steepness",
            "tyre_model_gate_speed",
            "free_side_slip_time_constant",
            "tyre_peak_force_time_constant",
            "tyre_peak_hold_time",
            "tyre_peak_identification_time_constant",
            "tyre_peak_candidate_bound",
        ):
            require_in(f"mixing.{name}", getattr(self, name), "(0, inf)")
        require_in("mixing.free_side_slip_anchor", self.free_side_slip_anchor, "(0, 1)")
        for name in ("drag_acceleration", "drag_per_speed", "tyre_reference_speed"):
            require_in(f"mixing.{name}", getattr(self, name), "[0, inf)")

    def _check_slide_onset_and_tyre_peak(self):
        """The ranges of the slide-onset test and of the tyre peak's identification."""
        # inf: no per-sample test
        require_in("mixing.slide_onset_jump", self.slide_onset_jump, "(0, inf] m/s")
        for name, unit in (
            ("slide_onset_release", "m/s"),
            ("slide_onset_max_time", "s"),
            ("slide_onset_pair_tolerance", "m/s^2"),
        ):
            require_in(f"mixing.{name}", getattr(self, name), f"(0, inf) {unit}")
        lo = require_in("mixing.tyre_peak_evidence_slip", self.tyre_peak_evidence_slip, "(0, inf)")
        hi = self.tyre_peak_full_evidence_slip
        if not (math.isfinite(hi) and hi > lo):
            allowed = f"(tyre_peak_evidence_slip={lo!r}, inf)"
            raise out_of_range("mixing.tyre_peak_full_evidence_slip", hi, allowed)
        require_in("mixing.tyre_peak_min_ratio", self.tyre_peak_min_ratio, "(0, 1]")
        require_in("mixing.tyre_peak_max_ratio", self.tyre_peak_max_ratio, "[1, inf)")
        n = self.slide_onset_release_samples
        require_integer("mixing.slide_onset_release_samples", n, "an integer in [1, 1000]")
