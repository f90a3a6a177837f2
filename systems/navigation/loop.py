"""The plain sequential reference loop of Seyr & Jakubek's Fig. 3 (its parameters: parameters.py).

``navigation_loop`` runs the same pure functions as the LeafSystems of diagrams/navigation.py, in the
order the diagram's timing implies, over logged sensor rows. It is the test oracle that proves the
diagram's multi-rate wiring (sample-for-sample agreement) and the baseline of the speed benchmark.

Ordering at each sample k (time t_k = k T_N; n = T_C/T_N; control instants k = K n):
1. check every sensor channel (systems/health/: exclude and replace faulty ones, flag them),
   odometry S(10) from the encoder difference;
   the gyro and the odometric yaw rate calibrated with the bias and radius difference learned up to
   the last batch (systems/navigation/yaw_calibration.py); the accelerometers less the biases learned up to
   sample k-1 and the standstill test of sample k (systems/navigation/standstill.py);
2. EKF: prediction S(2) of the previous mixed estimate, update S(8) with the gain L in force -> ^I x_k;
3. slip detector S(11) accumulates; C2 S(13), C3 S(14) from ^I x_k and odometry (C3 of the residual's
   PT1 up to sample k, times the odometric yaw rate's share from the calibration's covariance as it
   stood after the last batch, systems/navigation/calibrated_signals.py);
4. mixing S(15)-(17) with the C1 in force, zero while the robot stands (the zero-velocity update) ->
   mixed estimate (the navigation output of sample k);
5. updates: EKF state <- mixed estimate, P <- S(9) and the mixing as pseudo-measurements
   (ekf_covariance_update with the mixed estimate's mixing_gain); pose S(21); odometry-only and
   Gyrodometry poses (the raw gyro and the raw odometry); the calibration from the raw gyro, the raw
   odometry and the C1 in force (its Kalman update at each batch's end); the C3 residual; the
   standstill test's state and the accelerometer biases (their Kalman update while standing);
   at control instants also C1 S(12) from this batch's dv and the batches' leaky sum, L S(7) from
   P_{k|k-1}, S(18)-(20) from the mixed estimate, and the detector's reset. C1, L and alpha computed
   at t_K act from sample k+1 on.
Logged values are those the blocks read at t_k: states before step 5, outputs of steps 1-4.
"""

import numpy as np
from slipnav.systems.health import (
    NO_CURRENTS,
    gyro_bias_step,
    health_check,
    health_constants,
    health_flags,
    health_initial_state,
    odometry_unusable,
    yaw_pair_witness,
    yaw_verdict,
)
from slipnav.systems.navigation.baselines import BaselineState, baselines_step
from slipnav.systems.navigation.calibration_batches import believed_tyre_slip
from slipnav.systems.navigation.ekf import (
    ekf_covariance_update,
    ekf_gain,
    ekf_inertial_estimate,
    ekf_measurement,
    ekf_prior_covariance,
    joseph_factors,
)
from slipnav.systems.navigation.mixing.mixer import mix_checked, mixing_gain, push_taken
from slipnav.systems.navigation.mixing.slide_onset import (
    SLIDE_ONSET_INITIAL,
    accelerometer_pair_disagreement,
    slide_onset_step,
)
from slipnav.systems.navigation.mixing.tyre_identification import believed_tyre
from slipnav.systems.navigation.mixing.weights import (
    c3_residual,
    c3_turn_rate,
    mixer_c1_step,
    mixing_c2,
    mixing_c3,
)
from slipnav.systems.navigation.odometry import odometry_step, wheel_radii
from slipnav.systems.navigation.parameters import NavigationBelief
from slipnav.systems.navigation.pose import pose_step
from slipnav.systems.navigation.sensor_correction import corrected_accelerometers, corrected_gyro
from slipnav.systems.navigation.sideslip import side_slip_angle
from slipnav.systems.navigation.slip_detector import slip_detector_batch_end, slip_detector_step
from slipnav.systems.navigation.standstill import (
    accelerometer_biases,
    bias_free,
    standstill_constants,
    standstill_initial_state,
    standstill_step,
    standstill_test,
    zero_velocity_update,
)
from slipnav.systems.navigation.yaw_calibration import (
    CALIBRATION_LAYOUT,
    believed_gyro,
    calibrated_gyro,
    calibrated_odometry,
    odometric_yaw_share,
    yaw_calibration_initial_state,
    yaw_calibration_step,
)
from slipnav.systems.robot.faults import SENSOR_CHANNELS
from slipnav.systems.state_layout import layout_slices

_CALIBRATION_COVARIANCE = layout_slices(CALIBRATION_LAYOUT)["covariance"]
"""The covariance of [b_g, D] in the calibration's state (row-major)."""

LOOP_KEYS = (
    "est_x est_y est_phi est_v_t est_v_n est_omega est_a_t est_a_n est_alpha est_track_speed "
    "odo_x odo_y odo_phi gyro_x gyro_y gyro_phi C1 C2 C3 slide_onset tyre_model_weight free_v_n "
    "est_tyre_peak delta_v "
    "odo_v_t odo_omega fault est_gyro_bias standstill est_accel_bias_t1 est_accel_bias_n1 "
    "est_accel_bias_t2 est_accel_bias_n2"
).split() + [f"health_{channel}" for channel in SENSOR_CHANNELS]


class NavigationLoop:
    """The navigation algorithm as a plain sequential stepper (the module's ordering), one T_N sample per
    ``step``. ``navigation_loop`` runs it over logged rows; the closed-loop reference loop
    (scenarios/plain_loop.py) runs it on line with the plant.

    Args:
        belief: what the navigation is given (NavigationBelief: the tuning, the believed geometry, the
            periods, the initial state, the data sheet, the calibration and the nominal robot).
    """

    def __init__(self, belief: NavigationBelief):
        params, initial, T_N = belief.params, belief.initial, belief.rates.T_N
        r_R, r_L = wheel_radii(belief.wheel_radius)
        calibration = belief.calibration
        identity = calibration is None or calibration.validate().is_identity()
        self.sensor_calibration = None if identity else calibration
        self.geometry = belief.geometry()
        self.health = health_initial_state(self.geometry, initial.speed)
        self.health_constants = health_constants(params.health, self.geometry)
        self.standstill_constants = standstill_constants(params.standstill, self.geometry, T_N)
        self.standstill = standstill_initial_state(self.standstill_constants)
        self.wheel_radius = (r_R, r_L) if r_R != r_L else r_R
        self.params, self.track_width, self.T_N = params, belief.track_width, T_N
        self.n = belief.rates.batch_length
        self.Q, self.R, self.P = params.ekf.matrices()
        self.x = initial.ekf_state()
        self.L = ekf_gain(ekf_prior_covariance(self.P, self.x, self.Q, T_N), self.R)
        self.odo_state = initial.odometry_state()
        self.det_state = [0.0, 0.0, initial.speed, 0.0]
        self.c1, self.dv_held, self.dv_sum, self.alpha, self.v_track = 1.0, 0.0, 0.0, 0.0, 0.0
        self.pose = list(initial.pose)
        self.checked_encoders = (float("nan"), float("nan"))  # the sensor checks' angles of the last step
        self.baselines = BaselineState.initial(initial.pose, initial.speed)  # on the raw sensors
        believed = believed_tyre_slip(params.yaw_calibration, belief.robot, params.mixing, belief.track_width)
        self.yaw_calibration = believed_gyro(believed, belief.sensors)
        self.calibration = yaw_calibration_initial_state(self.yaw_calibration)
        self.c3_residual, self.c3_turn_rate = 0.0, 0.0
        self.tyre_model_state = (float(self.x[1]),) * 2 + (params.mixing.tyre_peak_acceleration, 0.0, 0.0)
        self.tyre_model_weight = 0.0  # mix_checked's
        self.inertial_fault = self.encoder_fault = False
        self.pushed = False  # the perturbation monitor's sideways push as the mixer takes it (step)
        self.slide_onset_state, self.slide_onset, self.c1_mixed = SLIDE_ONSET_INITIAL, False, self.c1
        self.k = 0

    @property
    def L(self) -> np.ndarray:
        """The Kalman gain S(7) in force (5 x 3, row-major as the diagram's ``kalman_gain`` port holds it:
        a matrix product rounds by its operands' layout); setting it also sets ``joseph``, S(9)'s
        joseph_factors of it, which update_estimate reads."""
        return self._L

    @L.setter
    def L(self, gain) -> None:
        self._L = np.ascontiguousarray(gain)
        self.joseph = joseph_factors(self._L, self.R)

    def velocity_mix(self, odo, inertial, c2: float, c3: float, previous, standing: bool) -> np.ndarray:
        """S(15)-(17) at sample ``self.k`` with the C1 in force (``c1_mixed``: 0 during a slide onset) and
        the tyre-model check (mix_checked,
        which updates ``tyre_model_state`` and ``tyre_model_weight``), then the zero-velocity update while
        ``standing``; ``previous`` is the EKF state x_k-1 (studies/error_budget.py overrides this to
        feed oracle inputs)."""
        mixed, self.tyre_model_weight, self.tyre_model_state = mix_checked(
            odo,
            inertial,
            self.c1_mixed,
            c2,
            c3,
            previous,
            self.params.mixing,
            self.tyre_model_state,
            self.T_N,
            self.inertial_fault,
            self.encoder_fault,
            self.pushed,
        )
        if standing:
            mixed, self.tyre_model_state = zero_velocity_update(mixed, self.tyre_model_state)
        return mixed

    def step(
        self, accelerometers, gyro: float, encoders, currents=NO_CURRENTS, external_force=False
    ) -> tuple:
        """Process sample k (``currents``: the motor drivers' readings, for the sensor checks;
        ``external_force``: the perturbation monitor's sideways push at t_k, for the mixer); returns
        the values the blocks output at t_k, in LOOP_KEYS order (the covariance P_k-1 is ``self.P``
        before the call)."""
        mp, T_N = self.params.mixing, self.T_N
        previous = tuple(self.x.tolist())  # x_k-1 as floats (the EKF unpacks it, the mixer reads it)
        raw, sample, codes, acc, g, corrected = self.checked_sensors(accelerometers, gyro, encoders, currents)
        unusable = odometry_unusable(self.health, sample)
        fault_imu, _, blind = health_flags(codes, unusable, self.geometry.accelerometer_sets)
        self.inertial_fault = fault_imu > 0.5  # the tyre-model check rests (velocity_mix)
        self.pushed = push_taken(external_force, self.inertial_fault)
        odo_next, odo_raw, odometry_held = odometry_step(
            self.odo_state, sample[5:7], self.wheel_radius, self.track_width, T_N
        )
        self.encoder_fault = any(codes[5:7])  # the tyre peak learns nothing (velocity_mix)
        fault_enc = max(odometry_held, 1.0 if self.encoder_fault else 0.0)
        cal, theta = self.yaw_calibration, self.calibration[0:2].tolist()  # [b_g, D] as floats
        odo = calibrated_odometry(odo_raw, theta, self.track_width, cal)
        gyro_calibrated = calibrated_gyro(g, theta, cal)
        measurement = ekf_measurement(acc, [gyro_calibrated])
        standing, standstill_test_state = standstill_test(
            self.standstill,
            acc,
            gyro_calibrated,
            self.checked_encoders,
            self.standstill_constants,
        )
        inertial = ekf_inertial_estimate(previous, self.L, measurement, T_N).tolist()  # floats for the mixing
        P_prior = ekf_prior_covariance(self.P, previous, self.Q, T_N)
        excluded = blind > 0.5
        det_next, _ = slip_detector_step(
            self.det_state, odo[0], acc, T_N, mp.delta_v_running_integral, excluded
        )
        c2, c3, residual, turn = self.mixing_weights(odo, inertial, acc)
        tyre_state = self.tyre_model_state
        mixed = self.velocity_mix(odo, inertial, c2, c3, list(previous), standing)
        row = self.output_row(mixed, c2, c3, odo_raw, max(fault_imu, fault_enc), theta[0], standing, codes)
        self.update_estimate(mixed, P_prior, c2, standing, tyre_state)
        baselines_step(
            self.baselines,
            raw[5:7],
            raw[4],
            self.wheel_radius,
            self.track_width,
            self.params.gyrodometry,
            T_N,
            self.sensor_calibration,
        )
        fault = fault_imu > 0.5 or fault_enc > 0.5
        self.update_calibrations(g, odo_raw, fault, standing, corrected, standstill_test_state)
        self.c3_residual, self.c3_turn_rate = residual, turn
        self.odo_state = odo_next
        self.det_state = det_next
        if self.k % self.n == 0:
            self.control_instant(odo, excluded, P_prior, mixed)
        self.k += 1
        return row

    def checked_sensors(self, accelerometers, gyro: float, encoders, currents) -> tuple:
        """Step 1's sensor checks (health_check, which updates ``health``; ``checked_encoders`` the checked
        angles), the model's calibration removed (SensorCorrection) and the accelerometers' learned
        biases (bias_free).

        Returns:
            (raw readings, checked sample, health codes, bias-free accelerometers, gyro, corrected
            accelerometers before bias_free)
        """
        raw = tuple([float(v) for v in (*accelerometers, gyro, *encoders)])
        amps = (float(currents[0]), float(currents[1]))
        velocity = (float(self.x[0]), float(self.x[1]))  # x_k-1's body velocity: the gyro's replacement
        peak = float(self.tyre_model_state[2])  # the identified tyre peak after x_k-1
        learned = (float(self.calibration[0]), float(self.calibration[1]))  # b_g, D before this sample
        self.health, sample, codes = health_check(
            self.health, raw, amps, self.health_constants, velocity, peak, learned
        )
        acc, g = sample[0:4], sample[4]
        self.checked_encoders = (sample[5], sample[6])  # what the perturbation monitor reads
        if self.sensor_calibration is not None:  # SensorCorrection
            cal = self.sensor_calibration
            acc, g = corrected_accelerometers(cal, acc), corrected_gyro(cal, g)
        corrected = acc
        acc = bias_free(self.standstill, corrected)  # StandstillDetector
        return raw, sample, codes, acc, g, corrected

    def mixing_weights(self, odo, inertial, acc) -> tuple:
        """Step 3's C2 S(13) and C3 S(14) (of the residual's and the turn rate's PT1 up to this sample) and
        the slide-onset test, which sets ``slide_onset_state``, ``slide_onset`` and the C1 the mixer
        takes (``c1_mixed``: 0 while the test holds).

        Returns:
            (C2, C3, filtered residual, filtered turn rate)
        """
        mp, T_N = self.params.mixing, self.T_N
        c2 = mixing_c2(inertial[4], mp)
        residual = c3_residual(self.c3_residual, odo[1], inertial[2], mp, T_N)
        turn = c3_turn_rate(self.c3_turn_rate, inertial[2], mp, T_N)
        covariance = self.calibration[_CALIBRATION_COVARIANCE].tolist()
        share = odometric_yaw_share(covariance, odo[0], self.track_width, self.yaw_calibration, T_N)
        c3 = mixing_c3(residual, mp, turn, share)
        disagreement = accelerometer_pair_disagreement(acc, inertial[2], self.geometry.accelerometer_position)
        self.slide_onset_state, self.slide_onset = slide_onset_step(
            self.slide_onset_state, odo[0], inertial[0], inertial[3], disagreement, mp, T_N
        )
        self.c1_mixed = 0.0 if self.slide_onset else self.c1
        return c2, c3, residual, turn

    def output_row(
        self, mixed, c2: float, c3: float, odo_raw, fault: float, bias: float, standing: bool, codes
    ) -> tuple:
        """The values the blocks output at t_k, in LOOP_KEYS order: the states before step 5 and the
        outputs of steps 1-4."""
        return (
            *self.pose,
            *mixed.tolist(),
            self.alpha,
            self.v_track,
            *self.baselines.odometry_pose,
            *self.baselines.gyrodometry[0:3],
            self.c1,
            c2,
            c3,
            1.0 if self.slide_onset else 0.0,
            self.tyre_model_weight,
            self.tyre_model_state[0],
            self.tyre_model_state[2],
            self.dv_held,
            odo_raw[0],
            odo_raw[1],
            fault,
            bias,
            1.0 if standing else 0.0,
            *accelerometer_biases(self.standstill),
            *codes,
        )

    def update_estimate(self, mixed, P_prior, c2: float, standing: bool, tyre_state) -> None:
        """Step 5's EKF state (the mixed estimate), its covariance (S(9) and the mixing's gain at the tyre
        peak believed before this sample, ``tyre_state``) and the pose S(21)."""
        self.x = mixed
        values = mixed.tolist()
        tyre = believed_tyre(self.params.mixing, tyre_state[2])
        gain = mixing_gain(values, self.c1_mixed, c2, tyre, self.tyre_model_weight, self.pushed, standing)
        self.P = ekf_covariance_update(P_prior, self.L, self.R, gain, self.params.ekf, self.joseph)
        self.pose = pose_step(self.pose, values[0], values[1], values[2], self.T_N)

    def update_calibrations(self, g: float, odo_raw, fault: bool, standing: bool, corrected, test) -> None:
        """Step 5's yaw-rate calibration (from the raw gyro and odometry and the C1 in force) and the
        standstill detector's state with the accelerometers' biases (``test``: standstill_test's state)."""
        rest = standing if self.params.standstill.enabled else None  # the detector's, else the wheels'
        self.calibration = yaw_calibration_step(
            self.calibration,
            g,
            odo_raw,
            self.c1,
            fault,
            self.track_width,
            self.yaw_calibration,
            self.T_N,
            self.n,
            rest,
            gyro_bias_step(self.health),
            yaw_pair_witness(self.health),
            yaw_verdict(self.health),
        )
        self.standstill = standstill_step(
            self.standstill, corrected, self.checked_encoders, standing, test, self.standstill_constants
        )

    def control_instant(self, odo, excluded: bool, P_prior, mixed) -> None:
        """Step 5 at a control instant: C1 S(12) from this batch's dv and the batches' leaky sum, the
        detector's reset, L S(7) from P_{k|k-1} and S(18)-(20) from the mixed estimate."""
        mp = self.params.mixing
        dv, self.det_state = slip_detector_batch_end(
            self.det_state, odo[0], self.n, excluded, mp.delta_v_running_integral
        )
        self.c1, self.dv_sum = mixer_c1_step(self.c1, self.dv_sum, dv, mp)
        self.dv_held = dv
        self.L = ekf_gain(P_prior, self.R)
        self.v_track, self.alpha, _ = side_slip_angle(mixed[0], mixed[1], mixed[2], self.params.sideslip)


def navigation_loop(accelerometers, gyro, encoders, belief: NavigationBelief):
    """Run the navigation algorithm sequentially over N sensor rows (as read at t_0 ... t_N-1).

    Args:
        accelerometers: (N, 4); gyro: (N,) or (N, 1); encoders: (N, 2).
        belief: what the navigation is given (NavigationBelief).

    Returns:
        dict of (N,) arrays keyed by LOOP_KEYS, plus ``P`` (N, 5, 5): the EKF covariance P_k-1 at t_k.
    """
    return run_navigation_loop(NavigationLoop(belief), accelerometers, gyro, encoders)


def run_navigation_loop(loop: NavigationLoop, accelerometers, gyro, encoders) -> dict:
    """Step ``loop`` over N sensor rows; returns what navigation_loop returns."""
    accelerometers = np.asarray(accelerometers, float)
    gyro = np.asarray(gyro, float).reshape(-1)
    encoders = np.asarray(encoders, float)
    N = len(gyro)
    rows = np.empty((N, len(LOOP_KEYS)))
    P = np.empty((N, 5, 5))
    for k in range(N):
        P[k] = loop.P
        rows[k] = loop.step(accelerometers[k], gyro[k], encoders[k])
    out = {key: rows[:, i].copy() for i, key in enumerate(LOOP_KEYS)}
    out["P"] = P
    return out
