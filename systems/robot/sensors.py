"""Proprioceptive sensors of Seyr & Jakubek §II, sampled at T_N: two two-axis accelerometers, one yaw
gyro and two quantised wheel encoders.

Default figures (tinyphoon) from data sheets of parts of the paper's era:
- Accelerometers: Analog Devices ADXL210E (dual-axis, +/-10 g, 500 ug/sqrt(Hz), 0 g drift ~2 mg/degC).
  With a 100 Hz output filter the rms noise is 500e-6 g * sqrt(1.6 * 100 Hz) = 6.3 mg = 0.062 m/s^2.
  Residual offset after calibration 5 mg, random-walk drift chosen so that ~2.5 degC of warming over a
  minute moves the offset by ~5 mg.
- Gyro: Analog Devices ADXRS300 (+/-300 deg/s, 0.1 deg/s/sqrt(Hz)); 40 Hz bandwidth gives
  0.1 * sqrt(1.6 * 40) = 0.8 deg/s = 0.014 rad/s rms; residual bias 0.2 deg/s.
- Encoders: Faulhaber IE2-512 (512 lines, quadrature x4) on the motor of a 3:1 gearhead = 6144 counts per
  wheel revolution. Encoders are bias-free; their only error is quantisation (§IV-B).
- Scale factors and alignment: each sensor's reading is (1 + scale error) times the truth, each two-axis
  accelerometer's axes are turned by a misalignment angle about the vertical; both zero by default (a
  perfect sensor, as the data sheet's typical figure) and drawn from tolerances for a real robot
  (scenarios/tolerances.py).
- Motor current (the drivers' current sense, not used by the paper's navigation; the perturbation monitor's
  force balance, systems/health/perturbation.py): a shunt amplifier and a 10-bit ADC over twice the
  driver's current limit (Tinyphoon +-3 A: 5.9 mA a count, Kurt3D +-24 A: 47 mA), with white noise of
  about two counts rms from the PWM ripple (assumption) and a gain tolerance (current_scale_error).
- "Commotion" (§IV-A): vibration of the accelerometer readings, a first-order Gauss-Markov process with a
  5 ms correlation time whose standard deviation grows with speed (assumption, 0.3 m/s^2 per m/s).
"""

from __future__ import annotations

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import out_of_range, require_in

NOISE_CHANNELS = 14
"""Standard-normal inputs per sample: 4 accel white, 4 accel drift, 4 vibration, gyro white, gyro drift."""
NOISE_BLOCK = 1024
"""Samples per block of the sensor noise stream (SensorNoise)."""
NOISE_STREAM = 1
"""Second entropy word of the noise stream's seed ([seed, NOISE_STREAM, block]), apart from the initial
biases' ``default_rng(seed)`` and the tolerances' draws."""
CURRENT_NOISE_STREAM = 2
"""The motor current sense's own stream ([seed, CURRENT_NOISE_STREAM, block]; CURRENT_NOISE_CHANNELS
draws a sample), so that the other sensors' draws do not depend on it."""
CURRENT_NOISE_CHANNELS = 2


@dc.dataclass(frozen=True)
class SensorParameters:
    """Sensor model parameters (SI units).

    Args:
        accelerometer_position: body position (x, y) of accelerometer 1 (m); accelerometer 2 sits at the
            opposite position (-x, -y), so that the mean of the two cancels the rotational terms.
        accel_noise_std: white noise per sample (m/s^2).
        accel_initial_bias_std: standard deviation of the initial offset (m/s^2).
        accel_drift_density: bias random walk (m/s^2 per sqrt(s)).
        accel_vibration_per_speed: commotion standard deviation per m/s of |v_t| (m/s^2 per m/s).
        accel_vibration_time_constant: correlation time of the commotion (s).
        accel_range: full scale (m/s^2); readings clip there.
        gyro_noise_std: white noise per sample (rad/s).
        gyro_initial_bias_std: standard deviation of the initial bias (rad/s).
        gyro_drift_density: bias random walk (rad/s per sqrt(s)).
        gyro_range: full scale (rad/s).
        encoder_counts_per_revolution: counts per wheel revolution.
        gyro_scale_error: relative error of the gyro's sensitivity (reading = (1 + e) omega + bias).
        accel1_scale_error, accel2_scale_error: relative sensitivity error of each two-axis accelerometer.
        accel1_misalignment, accel2_misalignment: angle (rad, about the vertical, counter-clockwise) by
            which each accelerometer's (t, n) axes are turned against the body's.
        current_resolution: one count of the motor drivers' current sense (A).
        current_noise_std: its white noise per sample (A).
        current_scale_error: relative gain error of both current senses.
        inertial_hold_time: the longest time the accelerometers' and the gyro's stream repeats a reading
            while healthy (s, in [0, 1]): a driver that republishes its last message when the device has
            no new one. 0: every sample fresh (the simulated sensors). The stuck test allows it on top
            of its repeats (systems/health/analog.py).
        gyro_resolution, accel_resolution: one count of the gyro's and the accelerometers' converter
            (rad/s, m/s^2; 0: continuous readings, the simulated sensors): the clip test does not read a
            quantised reading's return to its largest level within a few counts of the rest as a rail
            (systems/health/analog.py).
        encoder_hold_time: the longest time between fresh wheel-angle readings while healthy (s, in
            [0, 10]): a log that holds or interpolates its angles between readings. 0: a fresh count every
            sample (the simulated encoders). The jump test lets the wheel speed change by
            max_wheel_acceleration over it (systems/health/encoders.py).
        accelerometer_sets: how many two-axis accelerometers the robot carries, 0, 1 or 2: set 1 (channels
            a_t1, a_n1) at accelerometer_position, set 2 (a_t2, a_n2) opposite it. An absent set reads NaN
            and is not judged by the checks (systems/health/analog.py).
    """

    accelerometer_position: tuple[float, float] = (0.02, 0.015)
    accel_noise_std: float = 0.062
    accel_initial_bias_std: float = 0.05
    accel_drift_density: float = 0.0065
    accel_vibration_per_speed: float = 0.3
    accel_vibration_time_constant: float = 0.005
    accel_range: float = 10 * 9.81
    gyro_noise_std: float = 0.014
    gyro_initial_bias_std: float = 0.0035
    gyro_drift_density: float = 0.0005
    gyro_range: float = math.radians(300.0)
    encoder_counts_per_revolution: int = 6144
    gyro_scale_error: float = 0.0
    accel1_scale_error: float = 0.0
    accel2_scale_error: float = 0.0
    accel1_misalignment: float = 0.0
    accel2_misalignment: float = 0.0
    current_resolution: float = 6.0 / 1024
    current_noise_std: float = 0.012
    current_scale_error: float = 0.0
    inertial_hold_time: float = 0.0
    gyro_resolution: float = 0.0
    accel_resolution: float = 0.0
    encoder_hold_time: float = 0.0
    accelerometer_sets: int = 2

    def __post_init__(self):
        nonneg = (
            "accel_noise_std accel_initial_bias_std accel_drift_density accel_vibration_per_speed "
            "gyro_noise_std gyro_initial_bias_std gyro_drift_density current_noise_std gyro_resolution "
            "accel_resolution"
        ).split()
        for name in nonneg:
            require_in(name, getattr(self, name), "[0, inf)")
        for name in ("accel_vibration_time_constant", "accel_range", "gyro_range", "current_resolution"):
            require_in(name, getattr(self, name), "(0, inf)")
        counts = self.encoder_counts_per_revolution
        if int(counts) != counts or not 1 <= counts <= 10**7:  # a whole number of counts
            raise out_of_range("encoder_counts_per_revolution", counts, "integers in [1, 10000000]")
        for name in ("gyro_scale_error", "accel1_scale_error", "accel2_scale_error", "current_scale_error"):
            require_in(name, getattr(self, name), "(-1, 1) (a sensitivity > 0)")
        for name in ("accel1_misalignment", "accel2_misalignment"):
            require_in(name, getattr(self, name), "(-pi/2, pi/2) rad")
        require_in("inertial_hold_time", self.inertial_hold_time, "[0, 1] s")
        require_in("encoder_hold_time", self.encoder_hold_time, "[0, 10] s")
        sets = self.accelerometer_sets
        if isinstance(sets, bool) or not isinstance(sets, (int, float)) or sets not in (0, 1, 2):
            raise out_of_range("accelerometer_sets", sets, "0, 1 or 2")
        if len(self.accelerometer_position) != 2:
            raise ValueError("accelerometer_position must be a pair (x, y) in metres")

    @property
    def encoder_step(self) -> float:
        """Angle of one encoder count (rad)."""
        return 2.0 * math.pi / self.encoder_counts_per_revolution


def default_sensor_parameters(robot_name: str) -> SensorParameters:
    """Sensor set of each reference robot. Kurt3D: a 1024-line quadrature encoder per wheel (4096 counts)."""
    if robot_name == "kurt3d":
        return SensorParameters(
            accelerometer_position=(0.1, 0.05),
            encoder_counts_per_revolution=4096,
            current_resolution=48.0 / 1024,
            current_noise_std=0.094,
        )
    return SensorParameters()


def initial_biases(params: SensorParameters, rng: np.random.Generator) -> np.ndarray:
    """Draw the initial accelerometer (4) and gyro (1) biases."""
    return np.concatenate(
        [
            params.accel_initial_bias_std * rng.standard_normal(4),
            params.gyro_initial_bias_std * rng.standard_normal(1),
        ]
    )


class SensorNoise:
    """The sensors' standard-normal draws of a run, a pure function of (seed, sample index).

    Row k (the draws the sensors' update at t_k reads) is row ``k % NOISE_BLOCK`` of block
    ``k // NOISE_BLOCK``, drawn as ``numpy.random.default_rng([seed, stream, block])
    .standard_normal((NOISE_BLOCK, channels))`` (stream NOISE_STREAM, NOISE_CHANNELS channels; the
    current sense's: current_noise): deterministic per seed, independent of the order
    in which rows are read, and drawn a block at a time (one block held), so that a run of any length
    needs no random number generator in the diagram and no state for it.
    """

    def __init__(self, seed: int, stream: int = NOISE_STREAM, channels: int = NOISE_CHANNELS):
        self.seed, self.stream, self.channels = int(seed), int(stream), int(channels)
        self._block, self._rows = None, None

    def rows(self, start: int, stop: int) -> np.ndarray:
        """Rows start ... stop-1 as a (stop - start, NOISE_CHANNELS) array."""
        first, last = start // NOISE_BLOCK, max(stop - 1, start) // NOISE_BLOCK
        blocks = [self._draw(b) for b in range(first, last + 1)]
        table = np.concatenate(blocks) if blocks else np.empty((0, self.channels))
        offset = first * NOISE_BLOCK
        return table[start - offset : stop - offset].copy()

    def row(self, k: int) -> list:
        """Row k as a list of floats (the sensors' update reads one per sample)."""
        block = k // NOISE_BLOCK
        if block != self._block:
            self._rows, self._block = self._draw(block).tolist(), block
        return self._rows[k - block * NOISE_BLOCK]

    def _draw(self, block: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, self.stream, block])
        return rng.standard_normal((NOISE_BLOCK, self.channels))


def sensor_noise(seed: int, num_steps: int) -> np.ndarray:
    """The (num_steps, NOISE_CHANNELS) draws the sensors of a run with ``seed`` read at t_0 ...
    t_{num_steps-1} (SensorNoise; the plain loop's and the diagram's noise)."""
    return SensorNoise(seed).rows(0, num_steps)


def current_noise(seed: int) -> SensorNoise:
    """The motor current sense's draws of a run with ``seed`` (its own stream)."""
    return SensorNoise(seed, CURRENT_NOISE_STREAM, CURRENT_NOISE_CHANNELS)


def current_sense(currents, noise, params: SensorParameters) -> list:
    """The drivers' current readings [i_R, i_L] (A): (1 + scale error) i plus white noise, rounded to
    the ADC's counts; NaN where the true current is not known (no plant current connected)."""
    q, gain, sigma = params.current_resolution, 1.0 + params.current_scale_error, params.current_noise_std
    out = []
    for i, n in zip(currents, noise, strict=True):
        counts = (gain * i + sigma * n) / q
        out.append(round(counts) * q if math.isfinite(counts) else math.nan)
    return out


def accelerometer_truth(body_acceleration, omega: float, position) -> list:
    """True readings [a_t1, a_n1, a_t2, a_n2] of the two accelerometers at +/- position.

    a_P = a_cg + omega_dot x r + omega x (omega x r): tangential a_t - omega_dot*y - omega^2*x, lateral
    a_n + omega_dot*x - omega^2*y. The mean of the two (as in S(3)) is the centre's acceleration.
    """
    a_t, a_n, omega_dot = body_acceleration
    px, py = position
    w2 = omega * omega
    dt = -omega_dot * py - w2 * px
    dn = omega_dot * px - w2 * py
    return [a_t + dt, a_n + dn, a_t - dt, a_n - dn]


def initial_accelerometers(bias0, params: SensorParameters) -> np.ndarray:
    """The accelerometers' reading before the first sample: their initial biases [t1, n1, t2, n2] (m/s^2),
    NaN on an absent set (SensorParameters.accelerometer_sets)."""
    reading = np.array(bias0[0:4], float)
    reading[2 * int(params.accelerometer_sets) :] = np.nan
    return reading


def sensor_frame(truth, params: SensorParameters) -> list:
    """The two accelerometers' true readings [t1, n1, t2, n2] as their own axes see them: turned by the
    misalignment gamma (t' = t cos g + n sin g, n' = -t sin g + n cos g) and scaled by 1 + scale error."""
    out = []
    for i, (gamma, scale) in enumerate(
        (
            (params.accel1_misalignment, params.accel1_scale_error),
            (params.accel2_misalignment, params.accel2_scale_error),
        )
    ):
        t, n = truth[2 * i], truth[2 * i + 1]
        c, s = math.cos(gamma), math.sin(gamma)
        out += [(1.0 + scale) * (c * t + s * n), (1.0 + scale) * (c * n - s * t)]
    return out


def sensor_update(internal, plant_state, body_acceleration, noise, params: SensorParameters, T_N: float):
    """One sample of all sensors.

    Args:
        internal: [accel bias (4), gyro bias, vibration (4)].
        plant_state: PlantState-ordered true state.
        body_acceleration: true [a_t, a_n, omega_dot].
        noise: NOISE_CHANNELS standard-normal draws: accelerometer white noise (0-3), accelerometer bias
            drift (4-7), vibration (8-11), gyro white noise (12), gyro bias drift (13).

    Returns:
        (internal', accelerometers [a_t1, a_n1, a_t2, a_n2], gyro [omega], encoders [theta_R, theta_L]),
        lists of floats.
    """
    v_t, omega = plant_state[3], plant_state[5]
    drift = params.accel_drift_density * math.sqrt(T_N)
    phi = math.exp(-T_N / params.accel_vibration_time_constant)
    vib_gain = math.sqrt(1.0 - phi * phi) * params.accel_vibration_per_speed * abs(v_t)
    truth = accelerometer_truth(body_acceleration, omega, params.accelerometer_position)
    if (
        params.accel1_misalignment
        or params.accel2_misalignment
        or params.accel1_scale_error
        or (params.accel2_scale_error)
    ):
        truth = sensor_frame(truth, params)
    limit = params.accel_range
    bias, vibration, accel = [], [], []
    for i in range(4):
        b = internal[i] + drift * noise[4 + i]
        v = phi * internal[5 + i] + vib_gain * noise[8 + i]
        a = truth[i] + b + v + params.accel_noise_std * noise[i]
        bias.append(b)
        vibration.append(v)
        accel.append(min(max(a, -limit), limit) if i < 2 * params.accelerometer_sets else math.nan)
    gyro_bias = internal[4] + params.gyro_drift_density * math.sqrt(T_N) * noise[13]
    gyro = min(
        max(
            (1.0 + params.gyro_scale_error) * omega + gyro_bias + params.gyro_noise_std * noise[12],
            -params.gyro_range,
        ),
        params.gyro_range,
    )
    step = params.encoder_step
    encoders = [math.floor(plant_state[6] / step) * step, math.floor(plant_state[7] / step) * step]
    return [*bias, gyro_bias, *vibration], accel, [gyro], encoders


class ProprioceptiveSensors(LeafSystem):
    """Accelerometers, gyro and wheel encoders sampled every T_N (periodic discrete update, offset 0).

    .. pydrake_system::

        name: ProprioceptiveSensors
        input_ports:
        - plant_state
        - body_acceleration
        - motor_currents
        output_ports:
        - accelerometers
        - gyro
        - encoders
        - gyro_bias
        - motor_currents

    - plant_state: true PlantState (10).
    - body_acceleration: true [a_t, a_n, omega_dot].
    - motor_currents (input, optional): the plant's true armature currents [i_R, i_L] (A).
    - motor_currents (output): the drivers' current readings [i_R, i_L] (A, current_sense; NaN while the
      input is unconnected).
    - accelerometers: [a_t1, a_n1, a_t2, a_n2] (m/s^2).
    - gyro: [omega] (rad/s).
    - encoders: quantised wheel angles [theta_R, theta_L] (rad).
    - gyro_bias: the true bias [b_g] (rad/s) in the gyro sample the outputs hold (for evaluation only).

    Timing: the sample taken at t_k = k*T_N is the value of the output ports from t_k on. A discrete block
    updating at the same t_k reads the previous sample (Drake's pre-update semantics), i.e. the sensors
    behave as an ADC with one sample of conversion latency. Periodic publishers (loggers) at t_k also run
    before the updates of t_k, so a log row at t_k holds exactly what the navigation blocks read at t_k.

    Before the first sample the outputs hold the readings of a robot that has been rolling at
    ``initial_wheel_rates`` (encoders one sample behind the initial angle zero; accelerometers and gyro
    reading their biases), so that differencing blocks start consistently.

    Args:
        params: SensorParameters.
        T_N: sampling period (s).
        bias0: initial [accel biases (4), gyro bias] (see initial_biases()).
        initial_wheel_rates: wheel angular speeds (rad/s) before t = 0.
        noise: the SensorNoise whose row k the update at t_k = k T_N reads (the noise is drawn from the
            seed, not by a Drake RandomSource, whose unrestricted update would copy the whole diagram
            state every sample); default SensorNoise(0).
        current_noise_stream: the current sense's draws (current_noise); default current_noise(noise.seed).
    """

    def __init__(
        self,
        params: SensorParameters,
        T_N: float,
        bias0=None,
        initial_wheel_rates=(0.0, 0.0),
        noise: SensorNoise | None = None,
        current_noise_stream: SensorNoise | None = None,
    ):
        super().__init__()
        self._params = params
        self._T_N = T_N
        self._noise = noise if noise is not None else SensorNoise(0)
        self._current_noise = current_noise_stream or current_noise(self._noise.seed)
        internal0 = np.zeros(9)
        if bias0 is not None:
            internal0[0:5] = bias0
        self._plant_state_port = self.DeclareVectorInputPort("plant_state", 10)
        self._acceleration_port = self.DeclareVectorInputPort("body_acceleration", 3)
        self._currents_port = self.DeclareVectorInputPort("motor_currents", 2)
        self._internal = self.DeclareDiscreteState(internal0)
        step = params.encoder_step
        theta_before = -np.asarray(initial_wheel_rates, float) * T_N
        self._accel = self.DeclareDiscreteState(initial_accelerometers(internal0, params))
        self._gyro = self.DeclareDiscreteState(internal0[4:5].copy())
        self._enc = self.DeclareDiscreteState(np.floor(theta_before / step) * step)
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)
        self.DeclareStateOutputPort("accelerometers", self._accel)
        self.DeclareStateOutputPort("gyro", self._gyro)
        self.DeclareStateOutputPort("encoders", self._enc)
        self._gyro_bias = self.DeclareDiscreteState(internal0[4:5].copy())  # internal[4], as an output
        self.DeclareStateOutputPort("gyro_bias", self._gyro_bias)
        self._currents = self.DeclareDiscreteState(np.full(2, np.nan))
        self.DeclareStateOutputPort("motor_currents", self._currents)

    @property
    def params(self) -> SensorParameters:
        return self._params

    @property
    def noise(self) -> SensorNoise:
        return self._noise

    def _update(self, context, discrete_state):
        k = round(context.get_time() / self._T_N)
        internal, accel, gyro, enc = sensor_update(
            discrete_state.get_value(self._internal).tolist(),
            self._plant_state_port.Eval(context).tolist(),
            self._acceleration_port.Eval(context).tolist(),
            self._noise.row(k),
            self._params,
            self._T_N,
        )
        discrete_state.set_value(self._internal, internal)
        discrete_state.set_value(self._accel, accel)
        discrete_state.set_value(self._gyro, gyro)
        discrete_state.set_value(self._enc, enc)
        discrete_state.set_value(self._gyro_bias, internal[4:5])
        if self._currents_port.HasValue(context):
            currents = self._currents_port.Eval(context).tolist()
            discrete_state.set_value(
                self._currents, current_sense(currents, self._current_noise.row(k), self._params)
            )
