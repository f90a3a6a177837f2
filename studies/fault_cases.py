"""The sensor-fault benchmark's cases (studies/faults.py): the injected faults per channel and class with
their magnitudes, the null faults, the plant perturbations, the keys a run measures, and the onset and
RMS measures they are judged by."""

import math

import numpy as np
from slipnav.scenarios.metrics import POSE_DELAY_SAMPLES, final_position_error, rms_position_error
from slipnav.systems.robot.faults import ENCODER_CHANNELS, SENSOR_CHANNELS, FaultEvent, apply_sensor_faults

FAULT_DURATION = 0.5
DETECTION_LIMIT = 0.1
ANALOG_KINDS = ("nan", "inf", "dropout", "bias", "scale", "spike", "saturation")
ENCODER_KINDS = ("nan", "inf", "stuck", "bias", "scale", "spike")
BIAS = {"gyro": 1.0, "accel": 5.0, "encoder": 200.0}
"""Bias steps: rad/s, m/s^2 (the accelerometer pair test's scale), encoder counts."""
SPIKE = {"gyro": 3.0, "accel": 40.0, "encoder": 1000.0}
"""One-sample spikes: rad/s, m/s^2, encoder counts (the issue's +1000-count spike)."""
SCALE = 1.0
"""Scale change: the reading (an encoder's increments) doubled."""
SATURATION_FRACTION = 0.5
"""Saturation: clipped at half the channel's largest fault-free reading."""
NULL_FAULT_CHANNELS = ("gyro", "accel1_t")
NULL_FAULT_BIAS = 1e-6
"""The null faults' bias step (rad/s, m/s^2): 1/14000 of the gyro's white noise, 1/62000 of the
accelerometers'; no check can see it and no estimate should change beyond rounding."""
MEASURED_KEYS = {
    "accel1_t": "meas_a_t1",
    "accel1_n": "meas_a_n1",
    "accel2_t": "meas_a_t2",
    "accel2_n": "meas_a_n2",
    "gyro": "meas_gyro",
    "encoder_R": "meas_enc_R",
    "encoder_L": "meas_enc_L",
}


def _kind_of(channel: str) -> str:
    return "encoder" if channel in ENCODER_CHANNELS else channel if channel == "gyro" else "accel"


def fault_cases(a: dict) -> list[dict]:
    """The faults of one fault-free run ``a``: every channel x class, as plain dicts (sweep jobs) with
    their onset (fault_onset) and the fault-free run's fused final error."""
    t = a["t"]
    moving = t > float(a["start_time"]) + 0.2
    cases = []
    for channel in SENSOR_CHANNELS:
        measured = a[MEASURED_KEYS[channel]]
        if channel in ENCODER_CHANNELS:  # the wheel's fastest moment
            signal = np.abs(np.gradient(measured, t))
            kinds = ENCODER_KINDS
        else:
            signal = np.abs(measured)
            kinds = ANALOG_KINDS
        peak = int(np.argmax(np.where(moving, signal, -1.0)))
        start = round(max(float(t[peak]) - 0.1, float(t[np.argmax(moving)])), 3)
        kind_of = _kind_of(channel)
        for kind in kinds:
            value = {
                "bias": BIAS[kind_of],
                "spike": SPIKE[kind_of],
                "scale": SCALE,
                "saturation": SATURATION_FRACTION * float(np.max(np.abs(measured[moving]))),
            }.get(kind, 0.0)
            case = {
                "channel": channel,
                "kind": kind,
                "start": start,
                "duration": FAULT_DURATION,
                "value": value,
            }
            case["onset_s"] = fault_onset(a, FaultEvent(**case))
            case["clean_fused_error_m"] = final_position_error(a, "est")
            case["clean_fused_run_rms_m"] = run_rms_error(a)
            cases.append(case)
    return cases


NOISE_LEVEL = {"gyro": 3 * 0.014, "accel": 3 * 0.062, "encoder": 0.0}
"""A fault has an effect once it changes a reading by more than three white-noise sigmas (the data
sheets', systems/robot/sensors.py); an encoder's by any count."""


def select_cases(cases: list[dict], channels=None, kinds=None) -> list[dict]:
    """The ``cases`` (fault_cases) on ``channels`` and of ``kinds`` (None: all); an unknown name is a
    ValueError naming the allowed ones."""
    for label, names, allowed in (
        ("channels", channels, SENSOR_CHANNELS),
        ("kinds", kinds, tuple(dict.fromkeys(ANALOG_KINDS + ENCODER_KINDS))),
    ):
        unknown = [repr(n) for n in names or () if n not in allowed]
        if unknown:
            raise ValueError(f"faults --{label}: unknown {', '.join(unknown)}; allowed: {', '.join(allowed)}")
    pairs = [
        (c, k) for c in SENSOR_CHANNELS for k in (ENCODER_KINDS if c in ENCODER_CHANNELS else ANALOG_KINDS)
    ]
    if not any((channels is None or c in channels) and (kinds is None or k in kinds) for c, k in pairs):
        raise ValueError(
            f"faults --channels {','.join(channels or ['(all)'])} --kinds {','.join(kinds or ['(all)'])}: no "
            f"such fault (encoders: {', '.join(ENCODER_KINDS)}; the others: {', '.join(ANALOG_KINDS)})"
        )
    return [
        c
        for c in cases
        if (channels is None or c["channel"] in channels) and (kinds is None or c["kind"] in kinds)
    ]


def null_fault_cases(cases: list[dict]) -> list[dict]:
    """The null faults (module docstring) of one fault-free run's ``cases`` (fault_cases): its bias
    faults on NULL_FAULT_CHANNELS with the bias NULL_FAULT_BIAS; their onset is NaN (no reading changes
    by more than the noise)."""
    return [
        {**c, "value": NULL_FAULT_BIAS, "onset_s": math.nan}
        for c in cases
        if c["kind"] == "bias" and c["channel"] in NULL_FAULT_CHANNELS
    ]


def fault_onset(clean: dict, event: FaultEvent) -> float:
    """The first time the fault changes what the navigation reads by more than NOISE_LEVEL: the fault
    applied to the fault-free run's readings (the faulty run equals it up to there)."""
    t = clean["t"]
    T_N = float(clean["T_N"])
    rows = np.column_stack([clean[MEASURED_KEYS[c]] for c in SENSOR_CHANNELS])
    k = int(np.searchsorted(t, event.start - 1e-9))
    if k >= len(t):
        return math.nan
    held, previous = rows[k - 1].tolist(), rows[k - 1].tolist()
    step = 1.0  # an encoder's count size does not matter for whether the value changes
    level = NOISE_LEVEL[_kind_of(event.channel)]
    while k < len(t) and t[k] < event.start + event.duration:
        read = apply_sensor_faults(float(t[k]), rows[k], held, previous, [event], T_N, step)
        i = event.index
        if not abs(read[i] - rows[k][i]) <= level:  # NaN and inf too
            return float(t[k])
        held, previous = read, rows[k].tolist()
        k += 1
    return math.nan


def run_rms_error(a: dict) -> float:
    """The fused estimate's RMS position error over run ``a`` against the truth of the instant it
    describes (POSE_DELAY_SAMPLES back; docs/artifacts.md): the same row's truth adds the robot's travel
    during the lag to both runs, which dilutes their ratio."""
    return rms_position_error(a, "est", POSE_DELAY_SAMPLES)


PERTURBATIONS = (
    ("wheel_lifted", "wheel_R"),
    ("wheel_held", "wheel_R"),
    ("wheel_pushed", "wheel_R"),
    ("body_push", "body_n"),
    ("body_push", "body_t"),
)
"""Plant perturbations (Indiveri et al. Fig. 5), 0.5 s from 1 s after the controller starts: the right
wheel lifted, held, pushed with 0.6 x the motor's stall torque; the body pushed at 5 m/s^2 x its mass to
the left and backwards."""


def perturbation_cases(scenario, a: dict) -> list[dict]:
    """The perturbations of one fault-free run ``a`` of ``scenario`` as sweep jobs."""
    robot = scenario.robot_parameters()
    values = {
        "wheel_pushed": 0.6 * robot.motor_constant * robot.motor_current_limit,
        "body_push": 5.0 * robot.mass,
    }
    start = round(float(a["start_time"]) + 1.0, 3)
    return [
        {
            "channel": channel,
            "kind": kind,
            "start": start,
            "duration": FAULT_DURATION,
            "value": -values[kind] if channel == "body_t" else values.get(kind, 0.0),
        }
        for kind, channel in PERTURBATIONS
    ]
