"""The sensor checks' state: one flat vector (the SensorHealthMonitor's discrete state) whose parts are
named in HEALTH_LAYOUT. Analog channels are [a_t1, a_n1, a_t2, a_n2, omega] (5 each), encoders
[theta_R, theta_L] (2 each), the accelerometer pair's axes [t, n] (2 each) and its sensors
[t1, n1, t2, n2] (4 each).

The checks bind each part to a name in a statement of its own (``hold = s[ANALOG_HOLD]``): compiled by
numba 0.68, writes through views unpacked from one tuple (``a, b = s[A], s[B]``) are lost."""

import math

import numpy as np
from slipnav.systems.health.yaw_witness import YAW_TEST_SIZE, yaw_test_initial_state
from slipnav.systems.state_layout import layout_size, layout_slices

CLIP_WINDOW_MAX = 50
"""The readings each analog channel's ring keeps for the clip test (clip_window at most this)."""
GAIN_SERIES = 6
"""The gain test's sums per axis: for each of its two regressors r, d r / var, r^2 / var, |r| / var."""
GAIN_WINDOW_MAX = 50
"""The informative samples the gain test's window keeps (gain_samples at most this)."""

READMISSION_LAYOUT = (("samples", 1), ("difference", 1), ("travel", 1))
"""An excluded channel's re-admission block (analog.readmission_sample), in order (name, size): its
samples, their summed difference from the replacement and the replacement's summed magnitude."""
_READMISSION = layout_slices(READMISSION_LAYOUT)
BLOCK_SAMPLES, BLOCK_DIFFERENCE, BLOCK_TRAVEL = (_READMISSION[k] for k in ("samples", "difference", "travel"))
READMISSION_SIZE = layout_size(READMISSION_LAYOUT)

HEALTH_LAYOUT = (
    # analog channels: the reference (the last accepted value, the gyro's less b_g, or the replacement),
    # the last raw reading, its repeat count, the inconsistency hold (1; the gain test's: GAIN_HOLD), the
    # samples excluded and whether the exclusion stands on saturation alone (analog.SATURATION_ALONE);
    # the magnitudes of the last CLIP_WINDOW_MAX readings of each (NaN: none) and the ring's position
    ("analog_reference", 5),
    ("analog_last", 5),
    ("analog_repeats", 5),
    ("analog_hold", 5),
    ("analog_excluded", 5),
    ("analog_saturated", 5),
    ("clip_ring", 5 * CLIP_WINDOW_MAX),
    ("clip_position", 1),
    # encoders: the last finite raw angle, the output angle less it, the last used increment, the still
    # samples and the travel predicted over them (summed, and summed in magnitude), the code, 1 while
    # the next increment spans an exclusion (lost), the last raw increment, 1 while the exclusion is for
    # a disagreement (suspect); the re-admission blocks (READMISSION_LAYOUT; the replacement is the
    # prediction) and the encoders' own travel in them
    ("encoder_last_raw", 2),
    ("encoder_output_offset", 2),
    ("encoder_increment", 2),
    ("encoder_still", 2),
    ("encoder_still_predicted", 2),
    ("encoder_still_predicted_abs", 2),
    ("encoder_code", 2),
    ("encoder_lost", 2),
    ("encoder_raw_increment", 2),
    ("encoder_suspect", 2),
    ("encoder_block_R", READMISSION_SIZE),
    ("encoder_block_L", READMISSION_SIZE),
    ("encoder_block_moved", 2),
    # the ground's speed anchored where the wheels last agreed (m/s, NaN: none) and the samples each
    # encoder has read its wheel against the ground (systems/health/ground_speed.py)
    ("ground_speed", 1),
    ("encoder_opposed", 2),
    # 1 when this sample's encoder output restored a stuck encoder's missed travel; the previous
    # odometric v_o (m/s); 1 when the accelerometer pair witnessed this sample's yaw rate
    ("travel_restored", 1),
    ("previous_odometric_speed", 1),
    ("pair_witness", 1),
    # the accelerometer pair: the averages of its disagreement (slow and fast), each sensor's averaged
    # distance from the kinematic reference and its level while the pair agreed, the pair's averaged
    # omega^2, the pair's learned offset a_1 - a_2 beyond the rotational terms and its variance, and the
    # offset's block: its samples, their summed disagreement and their summed noise variance
    ("pair_average", 2),
    ("pair_fast_average", 2),
    ("pair_deviation", 4),
    ("pair_level", 4),
    ("pair_omega_squared", 1),
    ("pair_offset", 2),
    ("pair_offset_variance", 2),
    ("pair_offset_block_count", 2),
    ("pair_offset_block_sum", 2),
    ("pair_offset_block_noise", 2),
    # the pair's gain test per axis: block averages of the disagreement, of the pair's mean, of half the
    # rotational difference and of the other axis's mean; the GAIN_SERIES sums; the samples numbered,
    # the entries in the window and the ring's position; the ring of products (axis, series, entry) and
    # the entries' sample numbers (axis, entry)
    ("gain_block_disagreement", 2),
    ("gain_block_mean", 2),
    ("gain_block_half_rotation", 2),
    ("gain_block_other", 2),
    ("gain_sums", 2 * GAIN_SERIES),
    ("gain_sample_number", 2),
    ("gain_count", 2),
    ("gain_position", 2),
    ("gain_products", 2 * GAIN_SERIES * GAIN_WINDOW_MAX),
    ("gain_numbers", 2 * GAIN_WINDOW_MAX),
    # the excluded gyro's re-admission block (READMISSION_LAYOUT, rad/s)
    ("gyro_block", READMISSION_SIZE),
    # a frozen gyro's repeats: the wheels' yaw rate run through them (NaN: none), the heading they
    # missed against it, the payback still due (rate per sample, samples left)
    ("frozen_gyro_shadow", 1),
    ("frozen_gyro_owed", 1),
    ("payback_rate", 1),
    ("payback_left", 1),
    # the excluded gyro's bias-step block: samples, sums of the residual and its square, the largest
    # |replacement|; the bias step handed over this sample (rad/s)
    ("bias_block_count", 1),
    ("bias_block_sum", 1),
    ("bias_block_squares", 1),
    ("bias_block_turn", 1),
    ("bias_step", 1),
    # the gyro's witness from the wheels (rad/s, NaN: restart), its PT1 over yaw_witness_lag (NaN:
    # restart), the yaw test's state (systems/health/yaw_witness.py) and its verdict on this sample
    # (gyro.gyro_yaw_check: 1 confirmed, -1 blamed, 0 not judged)
    ("yaw_witness", 1),
    ("yaw_witness_smooth", 1),
    ("yaw_test", YAW_TEST_SIZE),
    ("yaw_verdict", 1),
)
"""The checks' state, in order (name, size)."""

_SLICES = layout_slices(HEALTH_LAYOUT)
STATE_SIZE = layout_size(HEALTH_LAYOUT)
ANALOG_REFERENCE, ANALOG_LAST, ANALOG_REPEATS = (
    _SLICES[k] for k in ("analog_reference", "analog_last", "analog_repeats")
)
ANALOG_HOLD, ANALOG_EXCLUDED = _SLICES["analog_hold"], _SLICES["analog_excluded"]
ANALOG_SATURATED = _SLICES["analog_saturated"]
CLIP_RING, CLIP_POSITION = _SLICES["clip_ring"], _SLICES["clip_position"]
ENCODER_LAST_RAW, ENCODER_OUTPUT_OFFSET = _SLICES["encoder_last_raw"], _SLICES["encoder_output_offset"]
ENCODER_INCREMENT, ENCODER_STILL = _SLICES["encoder_increment"], _SLICES["encoder_still"]
ENCODER_STILL_PREDICTED = _SLICES["encoder_still_predicted"]
ENCODER_STILL_PREDICTED_ABS = _SLICES["encoder_still_predicted_abs"]
ENCODER_CODE, ENCODER_LOST = _SLICES["encoder_code"], _SLICES["encoder_lost"]
ENCODER_RAW_INCREMENT, ENCODER_SUSPECT = _SLICES["encoder_raw_increment"], _SLICES["encoder_suspect"]
ENCODER_BLOCK_R, ENCODER_BLOCK_L = _SLICES["encoder_block_R"], _SLICES["encoder_block_L"]
ENCODER_BLOCK_MOVED = _SLICES["encoder_block_moved"]
GROUND_SPEED, ENCODER_OPPOSED = _SLICES["ground_speed"], _SLICES["encoder_opposed"]
TRAVEL_RESTORED = _SLICES["travel_restored"]
PREVIOUS_ODOMETRIC_SPEED = _SLICES["previous_odometric_speed"]
PAIR_WITNESS = _SLICES["pair_witness"]
PAIR_AVERAGE, PAIR_FAST_AVERAGE = _SLICES["pair_average"], _SLICES["pair_fast_average"]
PAIR_DEVIATION, PAIR_LEVEL = _SLICES["pair_deviation"], _SLICES["pair_level"]
PAIR_OMEGA_SQUARED = _SLICES["pair_omega_squared"]
PAIR_OFFSET, PAIR_OFFSET_VARIANCE = _SLICES["pair_offset"], _SLICES["pair_offset_variance"]
PAIR_OFFSET_BLOCK_COUNT = _SLICES["pair_offset_block_count"]
PAIR_OFFSET_BLOCK_SUM = _SLICES["pair_offset_block_sum"]
PAIR_OFFSET_BLOCK_NOISE = _SLICES["pair_offset_block_noise"]
GAIN_BLOCK_DISAGREEMENT, GAIN_BLOCK_MEAN = _SLICES["gain_block_disagreement"], _SLICES["gain_block_mean"]
GAIN_BLOCK_HALF_ROTATION = _SLICES["gain_block_half_rotation"]
GAIN_BLOCK_OTHER, GAIN_SUMS = _SLICES["gain_block_other"], _SLICES["gain_sums"]
GAIN_SAMPLE_NUMBER, GAIN_COUNT = _SLICES["gain_sample_number"], _SLICES["gain_count"]
GAIN_POSITION, GAIN_PRODUCTS = _SLICES["gain_position"], _SLICES["gain_products"]
GAIN_NUMBERS = _SLICES["gain_numbers"]
GYRO_BLOCK = _SLICES["gyro_block"]
FROZEN_GYRO_SHADOW, FROZEN_GYRO_OWED = _SLICES["frozen_gyro_shadow"], _SLICES["frozen_gyro_owed"]
PAYBACK_RATE, PAYBACK_LEFT = _SLICES["payback_rate"], _SLICES["payback_left"]
BIAS_BLOCK_COUNT, BIAS_BLOCK_SUM = _SLICES["bias_block_count"], _SLICES["bias_block_sum"]
BIAS_BLOCK_SQUARES, BIAS_BLOCK_TURN = _SLICES["bias_block_squares"], _SLICES["bias_block_turn"]
BIAS_STEP = _SLICES["bias_step"]
YAW_WITNESS, YAW_WITNESS_SMOOTH = _SLICES["yaw_witness"], _SLICES["yaw_witness_smooth"]
YAW_TEST, YAW_VERDICT = _SLICES["yaw_test"], _SLICES["yaw_verdict"]

_NOT_READ_YET = (
    "analog_reference",
    "analog_last",
    "clip_ring",
    "encoder_last_raw",
    "encoder_output_offset",
    "encoder_raw_increment",
    "pair_level",
    "frozen_gyro_shadow",
    "yaw_witness",
    "yaw_witness_smooth",
)
"""The parts that start as NaN: nothing read yet."""


def health_initial_state(g, initial_speed: float = 0.0) -> np.ndarray:
    """Nothing read yet (the first finite reading is accepted); wheels rolling at ``initial_speed`` (m/s);
    the pair's offset known to the two sensors' initial biases (``g``: HealthGeometry)."""
    s = np.zeros(STATE_SIZE)
    for name in _NOT_READ_YET:
        s[_SLICES[name]] = math.nan
    s[ENCODER_INCREMENT] = [initial_speed * g.T_N / g.radius_R, initial_speed * g.T_N / g.radius_L]
    s[PREVIOUS_ODOMETRIC_SPEED] = s[GROUND_SPEED] = initial_speed
    s[PAIR_OFFSET_VARIANCE] = 2.0 * g.accel_initial_bias_std**2  # two sensors' biases
    s[YAW_TEST] = yaw_test_initial_state()
    return s


def gyro_bias_step(state) -> float:
    """The gyro bias step (rad/s) the checks of this sample hand to the calibration (0: none;
    gyro_bias_step_block)."""
    return float(state[BIAS_STEP])


def yaw_verdict(state) -> int:
    """The yaw test's verdict on the gyro at this sample (gyro.gyro_yaw_check): 1 when it judged the gyro
    over a turn and holds no evidence against it (yaw_witness.yaw_test_verdict), -1 when it blamed the
    gyro (excluded as inconsistent with the wheels and the third witnesses), 0 otherwise."""
    return int(state[YAW_VERDICT])


def yaw_pair_witness(state) -> bool:
    """The accelerometer pair witnessed the yaw rate on this sample (gyro.pair_witnesses, and no
    accelerometer excluded): the third witness that isolates gyro or wheels (yaw_calibration_step)."""
    return bool(state[PAIR_WITNESS] > 0.0)


def travel_restored(state) -> bool:
    """This sample's encoder output restored a stuck encoder's missed travel."""
    return state[TRAVEL_RESTORED] > 0.0
