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

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.navigation.mixing.parameters import MixingParameters
from slipnav.systems.navigation.mixing.slide_onset import (
    SLIDE_ONSET_INITIAL,
    accelerometer_pair_disagreement,
    slide_onset_step,
)
from slipnav.systems.navigation.mixing.tyre_curve import (
    inertial_relaxation,
    lateral_velocity_model,
    longitudinal_slip_speed,
    mixing_utilisation,
    side_slip_from_accelerations,
    tyre_utilisation,
)
from slipnav.systems.navigation.mixing.tyre_identification import (
    believed_tyre,
    free_side_slip_step,
    tyre_model_check,
    tyre_peak_step,
)
from slipnav.systems.navigation.standstill import zero_velocity_update


def wheels_at_rest(odo) -> bool:
    """Neither wheel turned this sample: the odometric v_t and omega are both exactly 0."""
    return odo[0] == 0.0 and odo[1] == 0.0


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
    While the robot stands (``standing``: the zero-velocity update, systems/navigation/standstill.py) both
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
    at_rest = wheels_at_rest(odo)
    v_t, omega = tangential_and_yaw_mix(odo, inertial, c1, c3, at_rest, p)
    target, side_slip = lateral_mix(v_t, omega, odo, inertial, previous, c2, p)
    check, free, curve = 0.0, None, None
    pushed = check_state is not None and push_taken(external_force, inertial_fault)
    if check_state is not None and not inertial_fault:
        increment = inertial[1] - previous[1]
        check, free, curve, target = _checked_target(
            check_state, increment, target, v_t, pushed, side_slip, p
        )
    v_n = free if pushed else side_slip(inertial[1], previous[1], target)
    next_state = None
    if check_state is not None:
        next_state = _check_state_after(free, curve, v_n, inertial[4], inertial_fault, pushed, p, T_N)
    if identify:
        learn = not (inertial_fault or encoder_fault or at_rest or pushed)
        free_v_n = next_state[0] if inertial_fault else free
        peak = tyre_peak_step(
            check_state[2:5], odo[0], v_t, free_v_n, inertial[3], inertial[4], learn, nominal, T_N
        )
        next_state = (*next_state, *peak)
    return np.array([v_t, v_n, omega, inertial[3], inertial[4]]), check, next_state


def tangential_and_yaw_mix(odo, inertial, c1: float, c3: float, at_rest: bool, p: MixingParameters):
    """S(15) and the yaw rate's mix: (v_t, omega) = (C1 (^O v_t - s) + (1 - C1) ^I v_t, C3 ^O omega +
    (1 - C3) ^I omega), s = longitudinal_slip_speed(^O v_t, ^I a_t, ^I a_n), 0 while the wheels are
    ``at_rest`` (wheels_at_rest)."""
    # Wheels that did not turn this sample do not creep: their tyres hold the force (at a standstill
    # only the accelerometers' bias) by static friction.
    rolling = 0.0 if at_rest else odo[0] - longitudinal_slip_speed(odo[0], inertial[3], inertial[4], p)
    v_t = c1 * rolling + (1.0 - c1) * inertial[0]
    omega = c3 * odo[1] + (1.0 - c3) * inertial[2]
    return v_t, omega


def lateral_mix(v_t: float, omega: float, odo, inertial, previous, c2: float, p: MixingParameters):
    """S(17) at the mixed v_t and omega (mix): (f, side_slip). f is the inertial branch's target, the side
    slip at the measured forces (side_slip_from_accelerations), or the steady-turn model m
    (lateral_velocity_model) with side_slip_from_accelerations = False; side_slip(carried, relaxed_from,
    towards) = C2 [m_k + q2 (relaxed_from - m_k-1)] + (1 - C2) [towards + q_I (carried - towards)], with
    q_I = inertial_relaxation at the tyres' utilisation."""
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

    return target, side_slip


def _checked_target(check_state, increment: float, target: float, v_t: float, pushed: bool, side_slip, p):
    """The tyre-model check of mix_checked at this sample: (w, F, S, the inertial branch's target). F and S
    are ``check_state``'s carried by the EKF's v_n ``increment``; w = 1 while ``pushed``, else
    tyre_model_check(F, S, max(|v_t|, tyre_model_gate_speed)); the target moves towards F by w."""
    free = check_state[0] + increment
    curve = side_slip(check_state[1] + increment, check_state[1], target)
    check = 1.0 if pushed else tyre_model_check(free, curve, max(abs(v_t), p.tyre_model_gate_speed), p)
    if check > 0.0:
        target = target + check * (free - target)
    return check, free, curve, target


def _check_state_after(free, curve, v_n: float, a_n: float, inertial_fault: bool, pushed: bool, p, T_N):
    """The check's (F, S) after this sample: both the mixed ``v_n`` while an inertial channel is excluded;
    (F, S) as carried while ``pushed`` (neither anchored nor relaxed: the kinematics are all there is);
    else free_side_slip_step at the lateral utilisation |^I a_n| / a_peak."""
    if inertial_fault:
        return (v_n, v_n)
    if pushed:
        return (free, curve)
    return free_side_slip_step(free, curve, v_n, abs(a_n) / p.tyre_peak_acceleration, p, T_N)


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
    At a standstill the zero-velocity update (systems/navigation/standstill.py) replaces the whole estimate.

    Args:
        previous: the previous mixed estimate x_k-1 (the EKF state), for v_n,k-1 and m_k-1.
    """
    return mix_checked(odo, inertial, c1, c2, c3, previous, p, None, 0.0)[0]


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
    - standstill (optional): 1 while the robot stands (systems/navigation/standstill.py): the mixed estimate
      is zero and the check's F and S restart from rest (zero_velocity_update), applied to mix_checked's
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
