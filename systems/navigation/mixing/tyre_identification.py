"""The tyre-model check and the online identification of the tyres' peak force: a free integral of the
EKF's lateral kinematics weighed against the tyre curve's side slip (tyre_model_check,
free_side_slip_step), and the peak a_peak the curve uses, learnt from the navigation's own sensors
(tyre_peak_step, believed_tyre).
"""

import copy
import math

from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.tyre_curve import tyre_force_per_mass
from slipnav.systems.navigation.mixing.weights import logsig
from slipnav.systems.rates import pt1_step


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
    The drag is taken at the wheels' speed, as S(15)'s creep takes it.

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
