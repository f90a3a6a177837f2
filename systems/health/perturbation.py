"""Perturbations of the robot's motion: a wheel held, pushed or lifted, the body pushed (Indiveri et al.
Fig. 5, "the robot was perturbed by hand"), flagged from what the robot itself knows: its own wheel
commands, its encoders (as the sensor checks pass them: an excluded one's replacement) and the
navigation's estimate.

The sensor checks (systems/health/) judge each sensor against the others; they cannot tell a
wheel stopped by a hand from a robot that was commanded to stop. The commands can: every T_N,

1. ``wheel_braked`` / ``wheel_driven`` (per wheel): the wheel's encoder speed leaves the band the speed
   loop can follow (between the command and a reference that follows it at most at
   reference_acceleration, so that a current-limited run-up or a commanded stop is in the band) by more
   than speed_threshold + speed_fraction |command|, in a PT1 of time_constant: slower (held, blocked,
   pushed back) or faster (pushed on). A stuck or jumping count reads as its replacement, not as a braked
   or driven wheel.
2. ``yaw``: while both wheels are in their band, the body's yaw rate (the navigation's, the gyro's in a
   turn) leaves the wheels' by more than yaw_threshold + yaw_fraction |omega_wheels| (PT1): a wheel off
   the ground, or a push that turns the robot. The tyres' own slip in a hard turn (the odometric yaw rate
   leads the gyro by 10-15 %) stays below it. While the navigation's slide-onset test holds
   (mixing.slide_onset_jump: the wheels slide along the ground) the wheels' yaw rate is not the
   ground's and the test pauses, its PT1 at 0: in the square's braking slides the follower steers the
   sliding wheels apart (1.5 rad/s) while the body does not turn.
3. ``body``: the lateral acceleration the navigation measures leaves the centripetal v_t omega by more than
   lateral_threshold + lateral_per_speed |v_t| + lateral_fraction |v_t omega| (PT1; the accelerometers'
   commotion grows with the speed, the tyres' side slip rate with the turn): a push from the side beyond
   what the tyres hold. A push the tyres do hold leaves that trace only while the side slip builds up, so
   ``body`` is also the side slip no tyre explains: the lateral velocity the kinematics integrate, L_k =
   v_n,k + q_L (L_k-1 + T_N (a_n - v_t omega) - v_n,k) (leaky towards the estimate with
   slide_time_constant), beyond slide_threshold + slide_per_speed |v_t| while the turn asks little of the
   tyres: |v_t omega| has stayed below slide_demand (its peak held with slide_demand_hold). Without lateral
   demand no tyre curve, whatever the floor's grip, lets the body gain side slip; only an outside force
   does (a slippery floor in a turn does not count; the recovery from a spin-out, where the estimate's own
   v_n is off by more than the bound, does). A confirmed episode of these lateral conditions is the
   sideways push the navigation takes as an outside force (sideways_push_update).

4. ``force`` (with the motor drivers' current sense): the body's force balance, from the believed
   (nominal) robot alone. A wheel's motor puts (k i - beta w - J w')/r on the ground; the body's mass
   times its measured a_t, less the nominal shoe drag, should be the two wheels' sum, and the yaw inertia
   times omega' their difference times b/2. What the motors do not explain, per unit mass and split by
   side (e_t +- e_psi)/2, is the force on each side a hand (or an obstacle) adds: a wheel pushed or
   held by torque -> that side only (wheel_driven along the wheel's motion, wheel_braked against); a push
   on the body along its heading -> both sides alike (``body``). Each term passes two PT1s of
   time_constant (the wheel and yaw accelerations are the differences of the filtered encoders' and
   estimate's rates); a side counts beyond force_threshold + force_fraction |a_t| (a mass or inertia tolerance
   scales with the acceleration). A lateral push has no trace in the motors; a lifted wheel neither
   (its motor's torque is what the free wheel takes): both are left to 2. and 3.

A condition counts once it has held for confirm_samples; the flag then shows in the output (one sample
later, as every state output). Thresholds: above the largest value in the fault-free built-in runs.

What cannot be seen without the current sense: a push the speed loop or the tyres absorb without the
motion changing (a wheel pushed within the motor's authority, a push below the tyres' grip while driving
straight) leaves no trace in the encoders and the estimate; the force balance (4.) sees the first and a
push along the heading; the slide test of 3. a sideways push the tyres hold. Without accelerometers
(SensorParameters.accelerometer_sets 0) the body's acceleration is not measured: only 1. and 2. run.
"""

import collections
import dataclasses as dc
import math

import numpy as np
from slipnav.systems.health.parameters import NO_CURRENTS, drive_torque, plausible_currents
from slipnav.systems.ranges import out_of_range, require_each, require_in
from slipnav.systems.robot.contact import shoe_drag
from slipnav.systems.robot.parameters import RobotParameters
from slipnav.systems.state_layout import layout_indices, layout_size

PERTURBATION_CHANNELS = ("wheel_R", "wheel_L", "yaw", "body")
"""The flags, in order: a wheel's code is WHEEL_BRAKED or WHEEL_DRIVEN; yaw and body 0 or 1."""
WHEEL_BRAKED, WHEEL_DRIVEN = 1, 2
_PREFIX = "perturbation_monitor."
"""The scenario key of PerturbationParameters, in the messages of its range checks."""


@dc.dataclass
class PerturbationParameters:
    """Thresholds of the perturbation monitor, each test stated in the module docstring; the fault-free
    built-ins' largest values are measured with studies/faults.py.

    Args:
        enabled: monitor (False: the output stays zero).
        time_constant: PT1 of every residual (s): 0.02, one T_C.
        confirm_samples: samples a condition must hold before it is flagged, in [1, 100].
        reference_acceleration: the rate (m/s^2) at which the band's reference follows a command: 2.0,
            below Kurt3D's ~3 m/s^2 at its current limit.
        speed_threshold, speed_fraction: a wheel's band tolerance (m/s, 1 of |command|); fault-free
            built-ins: at most 0.10 m/s.
        yaw_threshold, yaw_fraction: the yaw test's bound (rad/s, 1 of the wheels' |omega|); fault-free:
            at most 0.43 rad/s (corner) and Kurt3D's skid at 3.4 m/s on the circle.
        lateral_threshold, lateral_per_speed, lateral_fraction: the lateral test's bound (m/s^2, m/s^2
            per m/s, 1): the side slip's rate a_n - v_t omega grows with the turn's demand |v_t omega|;
            with 0.2 of it the fault-free built-ins, with the tolerance preset, peak at 0.89 of the bound.
        slide_time_constant: leak of the kinematic lateral velocity L towards the estimate (s).
        slide_threshold: the slide test's bound on |L| (m/s; inf: no slide test); fault-free built-ins: at
            most 0.75 of the bound, the benchmark's sideways pushes 1.2-5.3.
        slide_per_speed: the slide bound's growth with |v_t| (1).
        slide_demand: the slide test runs while |v_t omega| has stayed below this (m/s^2); inf: at any
            demand.
        slide_demand_hold: time constant with which the peak of |v_t omega| is held (s).
        force_threshold: the force test's bound (m/s^2; inf: no force test); fault-free built-ins at most
            0.60 m/s^2, 0.72 with the robot 25 % heavier than believed; the benchmark's pushes 2.5-3.2.
        force_fraction: the force bound's growth with |a_t| (1).
        push_demand: the held turn demand |v_t omega| (m/s^2) below which a sideways episode must have held
            once to reach the navigation as an outside force (sideways_push_update); 0: never, inf: any.
    """

    enabled: bool = True
    time_constant: float = 0.02
    confirm_samples: int = 5
    reference_acceleration: float = 2.0
    speed_threshold: float = 0.25
    speed_fraction: float = 0.15
    yaw_threshold: float = 1.2
    yaw_fraction: float = 0.2
    lateral_threshold: float = 1.5
    lateral_per_speed: float = 0.5
    lateral_fraction: float = 0.2
    slide_time_constant: float = 0.1
    slide_threshold: float = 0.025
    slide_per_speed: float = 0.015
    slide_demand: float = 1.0
    slide_demand_hold: float = 0.5
    force_threshold: float = 1.0
    force_fraction: float = 0.1
    push_demand: float = 0.5

    def __post_init__(self):
        names = "time_constant reference_acceleration speed_threshold yaw_threshold slide_time_constant"
        require_each(self, require_in, names + " slide_demand_hold lateral_threshold", "(0, inf)", _PREFIX)
        require_each(self, require_in, "force_threshold slide_threshold slide_demand", "(0, inf]", _PREFIX)
        names = "speed_fraction yaw_fraction lateral_per_speed lateral_fraction slide_per_speed"
        require_each(self, require_in, names + " force_fraction", "[0, inf)", _PREFIX)
        require_in(_PREFIX + "push_demand", self.push_demand, "[0, inf]")  # inf allowed
        n = self.confirm_samples
        if int(n) != n or not 1 <= n <= 100:  # a whole number of samples
            raise out_of_range(_PREFIX + "confirm_samples", n, "1 .. 100")

    def validate(self) -> "PerturbationParameters":
        self.__post_init__()
        return self


PERTURBATION_LAYOUT = (
    ("reference", 2),  # each wheel's reference, following its command at most at reference_acceleration
    ("wheel_residual", 2),  # each wheel's speed beyond its band (PT1, m/s)
    ("yaw_residual", 1),  # the body's yaw rate less the wheels' (PT1, rad/s)
    ("lateral_residual", 1),  # a_n less v_t omega (PT1, m/s^2)
    ("confirm_counts", 4),  # the samples each condition has held (PERTURBATION_CHANNELS)
    ("last_encoder", 2),  # the wheel angles of the previous sample (rad; NaN: none)
    ("force_stage1", 5),  # the force balance's first PT1: wheel rates (2), yaw rate, along, yaw moment
    ("force_stage2", 5),  # and its second (NaN: none yet)
    ("slide_velocity", 1),  # the slide test's lateral velocity L (m/s; NaN: none yet)
    ("held_demand", 1),  # the turn's lateral demand |v_t omega|, its peak held (m/s^2)
    ("sideways_count", 1),  # the samples the sideways condition has held
    ("sideways_push", 1),  # 1 while the navigation takes a sideways push (sideways_push)
    ("sideways_veto", 1),  # 1 once a wheel or yaw flag rose in the episode
    ("sideways_seen", 1),  # 1 once the episode held below push_demand
    ("force_residual", 2),  # each side's unexplained force per unit mass (m/s^2; FORCE_CHANNELS)
    ("flags", 4),  # the confirmed flags (PERTURBATION_CHANNELS)
)
"""The monitor's state, in order (name, size); the flags last."""
_INDEX = layout_indices(PERTURBATION_LAYOUT)
STATE_SIZE = layout_size(PERTURBATION_LAYOUT)
REFERENCE, WHEEL_RESIDUAL = _INDEX["reference"], _INDEX["wheel_residual"]
YAW_RESIDUAL, LATERAL_RESIDUAL = _INDEX["yaw_residual"], _INDEX["lateral_residual"]
CONFIRM_COUNTS, LAST_ENCODER = _INDEX["confirm_counts"], _INDEX["last_encoder"]
FORCE_STAGE1, FORCE_STAGE2 = _INDEX["force_stage1"], _INDEX["force_stage2"]
SLIDE_VELOCITY, HELD_DEMAND = _INDEX["slide_velocity"], _INDEX["held_demand"]
SIDEWAYS_COUNT, SIDEWAYS_PUSH = _INDEX["sideways_count"], _INDEX["sideways_push"]
SIDEWAYS_VETO, SIDEWAYS_SEEN = _INDEX["sideways_veto"], _INDEX["sideways_seen"]
FORCE_RESIDUAL, FLAGS = _INDEX["force_residual"], _INDEX["flags"]
FORCE_CHANNELS = ("force_R", "force_L")
"""The force_residual output: each side's force the motors do not explain, per unit mass (m/s^2)."""


def perturbation_initial_state() -> list[float]:
    """Nothing read yet: the encoders' last angles, the force balance's filters and L NaN."""
    state = [0.0] * STATE_SIZE
    for index in (*LAST_ENCODER, FORCE_STAGE1[0], SLIDE_VELOCITY):
        state[index] = math.nan
    return state


ForceModel = collections.namedtuple(
    "ForceModel",
    "radius_R radius_L track_width mass yaw_inertia wheel_inertia motor_constant motor_current_limit "
    "bearing_drag shoe_offset shoe_friction shoe_viscous_drag shoe_slip_speed shoe_normal_load",
)
"""The believed robot's figures the force test reads, as plain floats (a RobotParameters' properties
cost a call each, every sample)."""


def force_model(robot: RobotParameters) -> ForceModel:
    """The ForceModel of the believed robot."""
    return ForceModel(*[float(getattr(robot, name)) for name in ForceModel._fields])


def perturbation_step(
    state,
    command,
    encoders,
    estimate,
    params,
    radii,
    track_width: float,
    T_N: float,
    currents=NO_CURRENTS,
    robot: ForceModel | RobotParameters | None = None,
    sliding: bool = False,
    accelerations: bool = True,
):
    """One T_N update (module docstring).

    Args:
        state: PERTURBATION_LAYOUT's values (perturbation_initial_state at first).
        command: the wheel speed commands [v_R, v_L] (m/s) in force.
        encoders: the wheel angles [theta_R, theta_L] (rad) as the sensor checks pass them (an excluded
            encoder's replacement).
        estimate: the navigation's mixed estimate [v_t, v_n, omega, a_t, a_n].
        radii: the believed rolling radii (r_R, r_L) (m).
        currents: the drivers' current readings [i_R, i_L] (A); NaN or beyond PLAUSIBLE_CURRENT times
            the limit: no force test in this sample.
        robot: the believed robot for the force test, its ForceModel (faster) or RobotParameters; None:
            no force test.
        sliding: the navigation's slide-onset test holds this sample (the wheels slide): no yaw test.
        accelerations: the robot carries accelerometers, which measure the estimate's a_t, a_n; False: no
            body or force test (3., 4.).

    Returns:
        the next state (its last four entries: the flags, PERTURBATION_CHANNELS).
    """
    s = [float(v) for v in state]
    if not params.enabled:
        return s
    a = math.exp(-T_N / params.time_constant)
    # 1. each wheel against its command's band
    expected, outside, rates = wheel_band_test(s, command, encoders, radii, a, params, T_N)
    # 4. the force balance (with the current sense)
    along = False
    if accelerations:
        along = force_test(s, command, rates, currents, estimate, robot, outside, a, params, T_N)
    # 2. the body's yaw rate against the wheels'; 3. the lateral acceleration and the side slip
    omega_wheels = (expected[0] - expected[1]) / track_width
    yaw_beyond, sideways = body_tests(s, estimate, omega_wheels, sliding, a, params, T_N)
    sideways = sideways and accelerations
    conditions = (
        outside[0],
        outside[1],
        1 if not any(outside) and yaw_beyond else 0,
        1 if along or sideways else 0,
    )
    for j, condition in enumerate(conditions):  # confirmed over confirm_samples
        s[CONFIRM_COUNTS[j]] = s[CONFIRM_COUNTS[j]] + 1.0 if condition else 0.0
        s[FLAGS[j]] = float(condition) if s[CONFIRM_COUNTS[j]] >= params.confirm_samples else 0.0
    sideways_push_update(s, sideways, params)
    return s


def wheel_band_test(s, command, encoders, radii, a: float, params, T_N: float) -> tuple:
    """Test 1. (module docstring) on both wheels, updating their references, residuals and last angles
    in ``s``: returns (each wheel's speed clipped to its band (m/s), each wheel's condition (0,
    WHEEL_BRAKED, WHEEL_DRIVEN), each wheel's encoder rate (rad/s, NaN: none))."""
    expected, outside, rates = [0.0, 0.0], [0, 0], [math.nan, math.nan]
    step = params.reference_acceleration * T_N
    for w in range(2):
        cmd = float(command[w])
        s[REFERENCE[w]] = min(max(cmd, s[REFERENCE[w]] - step), s[REFERENCE[w]] + step)
        low, high = min(cmd, s[REFERENCE[w]]), max(cmd, s[REFERENCE[w]])
        theta, last = float(encoders[w]), s[LAST_ENCODER[w]]
        if math.isfinite(theta) and math.isfinite(last):
            rates[w] = (theta - last) / T_N
            speed = rates[w] * radii[w]
            expected[w] = min(max(speed, low), high)
            s[WHEEL_RESIDUAL[w]] = a * s[WHEEL_RESIDUAL[w]] + (1.0 - a) * (speed - expected[w])
        else:  # a missing sample, the first after it (it spans the gap) and the very first: the
            expected[w] = cmd  # residual holds, the wheel taken as commanded
        s[LAST_ENCODER[w]] = theta
        bound = params.speed_threshold + params.speed_fraction * max(abs(low), abs(high))
        sign = 1.0 if high > 0.0 else (-1.0 if low < 0.0 else 0.0)
        residual = s[WHEEL_RESIDUAL[w]]
        if sign == 0.0:  # commanded to stand: any motion beyond the bound is driven
            outside[w] = WHEEL_DRIVEN if abs(residual) > bound else 0
        elif residual * sign < -bound:
            outside[w] = WHEEL_BRAKED
        elif residual * sign > bound:
            outside[w] = WHEEL_DRIVEN
    return expected, outside, rates


def force_test(s, command, rates, currents, estimate, robot, outside, a: float, params, T_N: float) -> bool:
    """Test 4. (module docstring), with plausible currents and a believed robot: each side's unexplained
    force (stored in ``s``) beyond its bound on one side only sets that wheel's condition in ``outside``
    (braked against its motion, driven along it) unless set; True when both sides are beyond it alike (a
    push on the body)."""
    testable = (
        robot is not None
        and math.isfinite(params.force_threshold)
        and plausible_currents(currents, robot.motor_current_limit)
    )
    forces = unexplained_force(s, rates, currents, estimate, robot, a, T_N) if testable else None
    if forces is None:
        return False
    s[FORCE_RESIDUAL[0]], s[FORCE_RESIDUAL[1]] = forces
    bound = params.force_threshold + params.force_fraction * abs(float(estimate[3]))
    beyond = [abs(f) > bound for f in forces]
    if beyond[0] and beyond[1] and forces[0] * forces[1] > 0.0:
        return True  # both sides alike: a push on the body
    for w in range(2):
        if beyond[w] and not outside[w]:
            direction = float(command[w]) or s[REFERENCE[w]]
            outside[w] = WHEEL_BRAKED if forces[w] * direction < 0.0 else WHEEL_DRIVEN
    return False


def unexplained_force(s, rates, currents, estimate, robot, a: float, T_N: float):
    """Update the force balance's two PT1 stages in ``s`` (a PT2: the wheel and yaw accelerations are the
    differences of the second stage's quantised rates) and return each side's force the motors do not
    explain per unit mass [e_R, e_L] (m/s^2; module docstring, 4.), or None while a rate is missing."""
    if not (math.isfinite(rates[0]) and math.isfinite(rates[1])):
        return None
    r = (robot.radius_R, robot.radius_L)
    J, m, half = robot.wheel_inertia, robot.mass, 0.5 * robot.track_width
    drive = [drive_torque(currents[w], rates[w], robot) / r[w] for w in range(2)]
    v_t, v_n, omega, a_t = float(estimate[0]), float(estimate[1]), float(estimate[2]), float(estimate[3])
    shoe_t, shoe_moment = shoe_drag(v_t, v_n, omega, robot, 0.0, 0.0)
    x = (
        rates[0],
        rates[1],
        omega,
        m * a_t - drive[0] - drive[1] - shoe_t,
        -half * (drive[0] - drive[1]) - shoe_moment,
    )
    if math.isnan(s[FORCE_STAGE1[0]]):
        for i in range(5):
            s[FORCE_STAGE1[i]] = s[FORCE_STAGE2[i]] = x[i]
        return None
    last = [s[index] for index in FORCE_STAGE2]
    for i in range(5):
        s[FORCE_STAGE1[i]] = a * s[FORCE_STAGE1[i]] + (1.0 - a) * x[i]
        s[FORCE_STAGE2[i]] = a * s[FORCE_STAGE2[i]] + (1.0 - a) * s[FORCE_STAGE1[i]]
    f = [s[index] for index in FORCE_STAGE2]
    inertia = [J * (f[w] - last[w]) / (T_N * r[w]) for w in range(2)]
    along = (f[3] + inertia[0] + inertia[1]) / m
    yaw = f[4] + robot.yaw_inertia * (f[2] - last[2]) / T_N + half * (inertia[0] - inertia[1])
    yaw /= m * half
    return [0.5 * (along + yaw), 0.5 * (along - yaw)]


def body_tests(s, estimate, omega_wheels: float, sliding: bool, a: float, params, T_N: float) -> tuple:
    """Tests 2. and 3. (module docstring) on the navigation's ``estimate`` [v_t, v_n, omega, a_t, a_n]:
    returns (the yaw residual beyond its bound, the lateral acceleration or the side slip beyond
    theirs). ``omega_wheels``: the wheels' yaw rate in their bands (rad/s); ``sliding``: the yaw test
    pauses, its PT1 at 0."""
    v_t, omega, a_n = float(estimate[0]), float(estimate[2]), float(estimate[4])
    s[YAW_RESIDUAL] = 0.0 if sliding else a * s[YAW_RESIDUAL] + (1.0 - a) * (omega - omega_wheels)
    centripetal = v_t * omega
    s[LATERAL_RESIDUAL] = a * s[LATERAL_RESIDUAL] + (1.0 - a) * (a_n - centripetal)
    yaw_bound = params.yaw_threshold + params.yaw_fraction * abs(omega_wheels)
    lateral_bound = (
        params.lateral_threshold
        + params.lateral_per_speed * abs(v_t)
        + params.lateral_fraction * abs(centripetal)
    )
    slide = slide_step(s, v_t, float(estimate[1]), centripetal, a_n, params, T_N)
    return abs(s[YAW_RESIDUAL]) > yaw_bound, slide or abs(s[LATERAL_RESIDUAL]) > lateral_bound


def slide_step(s, v_t: float, v_n: float, centripetal: float, a_n: float, params, T_N: float) -> bool:
    """Update the slide test's state in ``s`` (L and the held demand; module docstring, 3.) and return
    whether the side slip is one no tyre explains (``centripetal``: v_t omega, the turn's demand)."""
    demand = abs(centripetal)
    held = math.exp(-T_N / params.slide_demand_hold) * s[HELD_DEMAND]
    s[HELD_DEMAND] = max(demand, held) if math.isfinite(demand) else held  # a NaN sample keeps the peak
    L = s[SLIDE_VELOCITY] + T_N * (a_n - centripetal)
    if not math.isfinite(L):  # the first sample
        L = v_n
    s[SLIDE_VELOCITY] = v_n + math.exp(-T_N / params.slide_time_constant) * (L - v_n)
    bound = params.slide_threshold + params.slide_per_speed * abs(v_t)
    return s[HELD_DEMAND] < params.slide_demand and abs(s[SLIDE_VELOCITY]) > bound


def sideways_push_update(s, sideways: bool, params) -> None:
    """The sideways push the navigation takes as an outside force (the mixer's external_force): the body
    test's lateral and slide conditions, confirmed, in an episode that held once while the turn's held
    demand was below push_demand and raised no wheel or yaw flag. After a turn the side slip the curve
    misses is the floor's (a slide's recovery) and the kinematics' integral, which carries v_t omega's
    errors, drifts: without the demand's gate a slow slide after a turn at low friction reads as a push. A
    wheel held, pushed or lifted turns the body about it: those lateral traces are the pivot's."""
    s[SIDEWAYS_COUNT] = s[SIDEWAYS_COUNT] + 1.0 if sideways else 0.0
    if not sideways:
        s[SIDEWAYS_VETO] = s[SIDEWAYS_SEEN] = 0.0
    elif s[HELD_DEMAND] < params.push_demand:
        s[SIDEWAYS_SEEN] = 1.0
    if s[FLAGS[0]] or s[FLAGS[1]] or s[FLAGS[2]]:
        s[SIDEWAYS_VETO] = 1.0
    confirmed = s[SIDEWAYS_COUNT] >= params.confirm_samples
    s[SIDEWAYS_PUSH] = 1.0 if confirmed and s[SIDEWAYS_SEEN] and not s[SIDEWAYS_VETO] else 0.0


def sideways_push(state) -> bool:
    """The monitor's ``state`` (perturbation_step) flags a sideways push on the body (sideways_push_update;
    mixing.mix_checked's ``external_force``)."""
    return state[SIDEWAYS_PUSH] > 0.5


def perturbation_report(t, arrays: dict) -> dict:
    """Per flagged channel of a run (``arrays[f"perturbation_{channel}"]``): the first flagged time (s),
    the flagged samples and, for a wheel, the samples braked and driven."""
    report = {}
    for channel in PERTURBATION_CHANNELS:
        codes = np.asarray(arrays[f"perturbation_{channel}"])
        flagged = np.flatnonzero(codes > 0)
        if len(flagged) == 0:
            continue
        entry = {"first_s": float(t[flagged[0]]), "samples": int(len(flagged))}
        if channel.startswith("wheel"):
            entry["braked"] = int(np.sum(codes == WHEEL_BRAKED))
            entry["driven"] = int(np.sum(codes == WHEEL_DRIVEN))
        report[channel] = entry
    return report
