"""Tuning of the online gyro/odometry calibration (systems/navigation/yaw_calibration.py), validated on
construction."""

import dataclasses as dc
import math

from slipnav.systems.ranges import out_of_range, require_each, require_flag, require_in


@dc.dataclass
class YawCalibrationParameters:
    """Tuning of the online gyro/odometry calibration.

    Args:
        enabled: calibrate (False: the EKF gets the raw gyro and the mixer the raw odometry, as in the
            paper).
        initial_bias_std: prior standard deviation of the gyro bias (rad/s); None: the believed gyro's
            data sheet (SensorParameters.gyro_initial_bias_std; Tinyphoon's ADXRS300: 0.0035, 0.2 deg/s).
        initial_radius_difference_std: prior standard deviation of D = e_R - e_L: 0.0082, each rolling
            radius uniform within +-1 % of the nominal (scenarios/tolerances.py), 0.01 sqrt(2/3).
        bias_drift_density: random walk of the bias (rad/s per sqrt(s)); None: the believed gyro's data
            sheet (SensorParameters.gyro_drift_density; Tinyphoon's: 0.0005).
        gyro_noise_std: the gyro's white noise per T_N sample (rad/s), which the odometric yaw rate's share
            in S(14) weighs (calibrated_signals.gyro_white_variance); None: the believed gyro's data sheet
            (SensorParameters.gyro_noise_std; Tinyphoon's: 0.014).
        yaw_slip_time: kappa (s): the wheels read the yaw rate high by kappa v alpha while the robot's yaw
            accelerates by alpha at speed v (the tyres' differential slip), which a moving batch's
            variance counts (calibration_batches.slip_variance); None: the believed robot's tyres
            (calibration_batches.believed_tyre_slip; 0 where no robot is believed).
        radius_drift_density: random walk of D (1 per sqrt(s)): 0, the rolling radii are constant over a
            run (tyre wear acts over hours). Above 0, D follows whatever the bias's drift hands it at
            constant speed, where b_g and D v/b cannot be told apart.
        measurement_std: standard deviation of a moving batch's residual (rad/s): 0.01, the gyro's noise
            over a batch (0.014/sqrt(10)) and one encoder count per batch (Tinyphoon 0.005 rad/s), with
            margin; the floor of a moving batch's measurement variance, which the observed variance of
            the residuals raises (calibration_batches.measurement_variance; over noise_batches).
        standstill_measurement_std: the same at standstill (no encoder count in the batch; rad/s): 0.005,
            the gyro's noise over a batch alone, with margin. A 1 s standstill learns the bias to ~0.7
            mrad/s before the robot moves, which D then cannot absorb.
        innovation_gate: a batch whose innovation exceeds this many sigmas is not learned from: 4 (unless
            it raises the bias-change alarm).
        trusted_c1: C1 S(12) at or above which the odometry has no tangential slip: 0.9.
        straight_yaw_rate: |batch mean of gyro - b_g| below which the robot drives straight (rad/s):
            0.05, > 10 sigma of the batch's gyro noise, so that the gate does not select on the noise.
        change_yaw_rate: |batch mean of the calibrated odometric yaw rate| below which the wheels say the
            robot drives straight enough for the bias-change test (rad/s): 0.15, the path follower's
            corrections on a straight; the tyres' differential slip at that rate (10-15 %) stays within
            the batch's measurement_std.
        steady_yaw_acceleration: the change of the calibrated odometric yaw rate and of the gyro's mean from
            the previous batch to this one, per second, below which both are steady enough for the change
            test (rad/s^2): 2.0, eight of Tinyphoon's encoder counts per batch; while the yaw rate changes
            the body's lags the wheels' by the tyres' slip (Kurt3D's turn-in: 0.07 rad/s for 4 batches)
            and by the streams' relative lag (a real robot's loggers).
        largest_bias_step: the largest change of the gyro bias the change test follows (rad/s): 0.15; a
            moving batch is tested only while the gyro less b_g stays within straight_yaw_rate +
            largest_bias_step (a body that turns while its wheels do not is sliding).
        change_run_length: mean number of tested batches between false alarms of the bias-change test
            (a CUSUM of the normalised innovation, systems/residual_test.py): 180000, one per hour.
        change_drift: the CUSUM's drift k (sigma): 0.5, soonest for a shift of one innovation sigma.
        noise_batches: the observed variance of the tested batches' innovations averages over this many of
            them (within innovation_gate: a change does not feed it): 100, 2 s of tested batches. The
            test normalises by the larger of it and the predicted S: a robot whose gyro and wheels agree
            less well than measurement_std says raises no alarm for that (Mehra's innovation-based
            adaptive estimate). The learned moving batches' observed variance averages alike.
        change_clip: |z| beyond this counts as this in the CUSUM (sigma): 2.5, so that an alarm needs
            h / (change_clip - change_drift) tested batches at least (5.5, 0.11 s at T_C = 20 ms): a
            turn's start or end, where a real robot's body and wheels disagree for 60-80 ms, raises none;
            a persistent bias change does.
    """

    enabled: bool = True
    initial_bias_std: float | None = None
    initial_radius_difference_std: float = 0.0082
    bias_drift_density: float | None = None
    gyro_noise_std: float | None = None
    yaw_slip_time: float | None = None
    radius_drift_density: float = 0.0
    measurement_std: float = 0.01
    standstill_measurement_std: float = 0.005
    innovation_gate: float = 4.0
    trusted_c1: float = 0.9
    straight_yaw_rate: float = 0.05
    change_yaw_rate: float = 0.15
    steady_yaw_acceleration: float = 2.0
    largest_bias_step: float = 0.15
    change_run_length: float = 180000.0
    change_drift: float = 0.5
    change_clip: float = 2.5
    noise_batches: float = 100.0

    def __post_init__(self):
        require_flag("yaw_calibration.enabled", self.enabled)
        if self.initial_bias_std is not None:  # None: the believed gyro's
            require_in("yaw_calibration.initial_bias_std", self.initial_bias_std, "(0, inf)")
        positive = (
            "initial_radius_difference_std measurement_std standstill_measurement_std "
            "innovation_gate straight_yaw_rate change_yaw_rate steady_yaw_acceleration largest_bias_step "
            "change_drift"
        )
        require_each(self, require_in, positive, "(0, inf)", "yaw_calibration.")
        for name in ("bias_drift_density", "gyro_noise_std", "yaw_slip_time", "radius_drift_density"):
            if getattr(self, name) is not None:  # None: the believed gyro's
                require_in(f"yaw_calibration.{name}", getattr(self, name), "[0, inf)")
        require_in("yaw_calibration.change_run_length", self.change_run_length, "(1, inf) batches")
        require_in("yaw_calibration.noise_batches", self.noise_batches, "[1, inf)")
        if not (math.isfinite(self.change_clip) and self.change_clip > self.change_drift):
            allowed = f"(change_drift={self.change_drift}, inf)"
            raise out_of_range("yaw_calibration.change_clip", self.change_clip, allowed)
        require_in("yaw_calibration.trusted_c1", self.trusted_c1, "[0, 1]")
