"""The analog channels' own checks and outputs: [a_t1, a_n1, a_t2, a_n2, omega], each judged alone
against its data sheet and its last accepted value (health codes 1-4), and the value each one outputs.

1. ``nonfinite``: NaN or inf.
2. ``saturated``: a reading at saturation_fraction of its data-sheet range (gyro 300 deg/s,
   accelerometers 10 g), or at a rail below it: the clip_samples-th return to one magnitude within
   clip_window readings with none larger between (clip_returns; a run of repeats counts once).
3. ``stuck``: a reading exactly repeated stuck_samples times beyond the stream's longest healthy hold
   (inertial_hold_time: a driver that republishes its last message; the sensors' white noise makes a
   repeat of a fresh reading practically impossible; a real ADC's quantum is stuck_tolerance).
4. ``jump``: the innovation test of S(2)'s prediction of omega and a (random walks: the prediction is
   the last accepted value, the gyro's less b_g) against what the robot can do in one sample
   (gyro_max_step, accel_max_step); ``recovering`` while the channel is excluded and still beyond it.

A channel out for saturation alone (its exclusion began at the rail; no hold, stuck count or step
beyond the jump bound since; NaN samples between keep it), with no witness left to judge it
(unwitnessed: the gyro without both encoders, an axis without its partner), comes back on a reading off
its rail that continues from its last one within the jump bound: a reading inside the range is the
sensor's own, and its replacement is then a value held from the rail that nothing checks. While
witnessed it is judged against its witness's replacement as after any exclusion.

A channel of an absent accelerometer set (SensorParameters.accelerometer_sets) is not judged. An
excluded or absent channel outputs its replacement (analog_outputs).
"""

import math

from slipnav.systems.compiled import jitable
from slipnav.systems.health.layout import (
    ANALOG_EXCLUDED,
    ANALOG_HOLD,
    ANALOG_LAST,
    ANALOG_REFERENCE,
    ANALOG_REPEATS,
    ANALOG_SATURATED,
    BLOCK_DIFFERENCE,
    BLOCK_SAMPLES,
    BLOCK_TRAVEL,
    CLIP_POSITION,
    CLIP_RING,
    CLIP_WINDOW_MAX,
    ENCODER_CODE,
    PAIR_OFFSET,
    PAYBACK_LEFT,
    PAYBACK_RATE,
)
from slipnav.systems.health.parameters import (
    GYRO,
    INCONSISTENT,
    JUMP,
    NONFINITE,
    NUM_ANALOG,
    RECOVERING,
    SATURATED,
    STUCK,
)

SATURATION_ALONE, SATURATION_RELEASED = 1.0, 2.0
"""layout.ANALOG_SATURATED's values besides 0: the channel's exclusion began at its rail and no other
test has judged it since (NaN samples, continuous readings and a witness's pending judgement keep it);
this sample's reading leaves the rail unwitnessed and is taken back."""

CLIP_MIN_COUNTS = 4.0
"""A quantised channel's rail lies at least this many counts above the lowest magnitude read since the
last larger one: noise of a count or two around a level returns to its largest one by itself."""


@jitable
def checks_off(s, raw) -> tuple:
    """The checks off (enabled False): a non-finite analog reading holds the last valid value (0.0
    before any); returns (out, codes) with codes NONFINITE for the non-finite channels."""
    codes = [0 if math.isfinite(v) else NONFINITE for v in raw]
    out, reference = list(raw), s[ANALOG_REFERENCE]
    for c in range(NUM_ANALOG):
        if codes[c]:
            out[c] = reference[c] if math.isfinite(reference[c]) else 0.0
        reference[c] = out[c]
    return out, codes


def analog_constants(c) -> dict:
    """analog_checks' figures of the record ``c`` (HealthConstants), per channel: analog_present
    (channel_present), saturation_level, max_step (the jump test's bound), clip_floor (CLIP_MIN_COUNTS
    counts: clip_returns); and stuck_repeats (stuck_samples - 1 beyond the stream's hold, hold_samples)."""
    ranges = (c.accel_range,) * 4 + (c.gyro_range,)
    quanta = (c.accel_resolution,) * 4 + (c.gyro_resolution,)
    return {
        "analog_present": tuple(channel_present(k, c.accelerometer_sets) for k in range(NUM_ANALOG)),
        "saturation_level": tuple(c.saturation_fraction * r for r in ranges),
        "max_step": (c.accel_max_step,) * 4 + (c.gyro_max_step,),
        "clip_floor": tuple(CLIP_MIN_COUNTS * q for q in quanta),
        "stuck_repeats": c.stuck_samples - 1 + hold_samples(c.inertial_hold_time, c.T_N),
    }


@jitable
def analog_checks(s, raw, bias: float, codes, p) -> None:
    """Writes codes[0:5] (1-4; ``inconsistent`` while a hold stands), the repeat counts, the last readings
    and the clip ring; ``bias``: the calibration's b_g; ``p``: HealthConstants."""
    reference = s[ANALOG_REFERENCE]
    last = s[ANALOG_LAST]
    repeats = s[ANALOG_REPEATS]
    hold = s[ANALOG_HOLD]
    excluded = s[ANALOG_EXCLUDED]
    saturated = s[ANALOG_SATURATED]
    ring = s[CLIP_RING]
    position = int(s[CLIP_POSITION])
    for c in range(NUM_ANALOG):
        x = raw[c]
        if not p.analog_present[c]:  # not judged: analog_outputs replaces it
            continue
        if not math.isfinite(x):  # last[c] keeps the reading an exit from the rail continues
            codes[c] = NONFINITE
            continue
        same = math.isfinite(last[c]) and abs(x - last[c]) <= p.stuck_tolerance
        repeats[c] = repeats[c] + 1 if same else 0
        # out on saturation alone while no hold stands and the reading moves continuously
        alone = saturated[c] > 0 and hold[c] == 0 and not abs(x - last[c]) > p.max_step[c]
        saturated[c] = SATURATION_ALONE if alone else 0.0
        last[c] = x
        # at the data-sheet range, or at a rail below it (clip_returns: read only when needed)
        if abs(x) >= p.saturation_level[c] or (
            p.clip_samples > 0
            and clip_returns(ring, CLIP_WINDOW_MAX * c, position, x, p.clip_floor[c], p) >= p.clip_samples
        ):
            codes[c] = SATURATED
            if hold[c] == 0 and (excluded[c] == 0 or alone):  # the saturation starts the exclusion
                saturated[c] = SATURATION_ALONE
        elif repeats[c] >= p.stuck_repeats:
            codes[c], saturated[c] = STUCK, 0.0
        elif alone and not witnessed(s, c, p.analog_present):
            saturated[c] = SATURATION_RELEASED  # back without a block (gyro.gyro_readmission)
        elif math.isfinite(reference[c]) and (
            abs(x - (bias if c == GYRO else 0.0) - reference[c]) > p.max_step[c]
        ):
            codes[c] = RECOVERING if excluded[c] > 0 else JUMP
        elif hold[c] > 0:
            codes[c] = INCONSISTENT
    for c in range(NUM_ANALOG):  # the ring of the readings' magnitudes (clip_returns)
        ring[CLIP_WINDOW_MAX * c + position] = abs(raw[c])
    s[CLIP_POSITION] = (position + 1) % CLIP_WINDOW_MAX


@jitable
def witnessed(s, c: int, present) -> bool:
    """Channel ``c``'s replacement comes from a witness: the gyro's from both encoders (healthy on the
    last sample), an accelerometer axis's from its partner (present and not excluded)."""
    if c == GYRO:
        return s[ENCODER_CODE][0] == 0.0 and s[ENCODER_CODE][1] == 0.0
    return present[c ^ 2] and s[ANALOG_EXCLUDED][c ^ 2] == 0.0


@jitable
def clip_returns(ring, base: int, position: int, x: float, floor: float, p) -> int:
    """How many times reading ``x`` returned to its magnitude (within stuck_tolerance) within the last
    clip_window readings since the last larger one, counting this one and a run of repeats once (the
    channel's ring of magnitudes ring[base : base + CLIP_WINDOW_MAX], the next slot at ``position``): a
    clipped channel returns to its rail again and again, noise never repeats a value. 0 unless the
    magnitudes read since the last larger one reach ``floor`` below |x| (clip_floor; 0 for a continuous
    channel): a quantised channel returns to its largest level by its own noise."""
    tol = p.stuck_tolerance
    magnitude = abs(x)
    larger = magnitude + tol  # a reading beyond it ends the search
    lowest = magnitude
    runs, newer_at = 1, True  # this reading is at its own magnitude
    for j in range(1, p.clip_window):
        y = ring[base + (position - j) % CLIP_WINDOW_MAX]
        if not math.isfinite(y):  # a gap does not split a run
            continue
        if y > larger:
            break
        if y < lowest:
            lowest = y
        at = abs(y - magnitude) <= tol
        if at and not newer_at:
            runs += 1
        newer_at = at
    return runs if magnitude - lowest >= floor else 0


@jitable
def hold_samples(hold_time: float, T_N: float) -> int:
    """The samples a stream's longest healthy hold ``hold_time`` (s) spans at T_N: the repeats a stuck
    test allows beyond its own count."""
    return math.ceil(hold_time / T_N - 1e-9)


@jitable
def readmission_sample(block, residual: float, replacement: float, noise: float, fixed: float, fraction):
    """Adds an excluded channel's ``residual`` against its ``replacement`` to its re-admission ``block``
    (layout.READMISSION_LAYOUT's values, updated in place). Returns the summed difference the block
    allows: ``noise`` sqrt(samples) + ``fixed`` + ``fraction`` of the replacement's summed magnitude."""
    block[BLOCK_SAMPLES] += 1.0
    block[BLOCK_DIFFERENCE] += residual
    block[BLOCK_TRAVEL] += abs(replacement)
    return noise * math.sqrt(block[BLOCK_SAMPLES]) + fixed + fraction * block[BLOCK_TRAVEL]


@jitable
def channel_present(c: int, accelerometer_sets: int) -> bool:
    """Channel ``c`` of [a_t1, a_n1, a_t2, a_n2, omega] exists on a robot with ``accelerometer_sets``
    two-axis accelerometers (0, 1 or 2; the gyro always)."""
    return c == GYRO or c < 2 * accelerometer_sets


@jitable
def analog_outputs(s, raw, bias: float, codes, gyro_replacement: float, rotation, present, out) -> None:
    """Writes out[0:5] and the references: the reading, else its replacement. The excluded gyro reads
    ``gyro_replacement`` (its witnesses' yaw rate, rad/s) plus b_g, which the navigation removes, and a
    frozen gyro's owed heading is paid back on it (gyro.frozen_gyro_shadow); an excluded accelerometer axis
    reads its partner's reading plus the pair's ``rotation`` (rotational difference with its
    angular-acceleration terms per axis t, n, m/s^2) and learned offset, else its reference carried along.
    Of the absent channels (not ``present``) set 2 reads set 1's output moved across the pair, so that
    S(3)'s mean is the body centre's; without accelerometers the four read 0 (monitor.health_flags)."""
    reference = s[ANALOG_REFERENCE]
    excluded = s[ANALOG_EXCLUDED]
    offset = s[PAIR_OFFSET]
    for c in range(NUM_ANALOG):
        if not present[c]:
            value = out[c ^ 2] - rotation[c % 2] - offset[c % 2] if present[c ^ 2] else 0.0
            out[c] = reference[c] = value if math.isfinite(value) else 0.0
            continue
        if codes[c] == 0:  # the reference is the gyro less b_g, as its replacement is
            out[c] = raw[c]
            reference[c] = raw[c] - (bias if c == GYRO else 0.0)
            excluded[c] = s[ANALOG_SATURATED][c] = 0.0
            continue
        excluded[c] += 1.0
        if c == GYRO:
            value = gyro_replacement
        elif codes[c ^ 2] == 0 and present[c ^ 2]:  # the partner's reading, plus the difference
            value = raw[c ^ 2] + (1.0 if c < 2 else -1.0) * (rotation[c % 2] + offset[c % 2])
        else:
            value = reference[c]
        out[c] = reference[c] = value if math.isfinite(value) else 0.0
        if c == GYRO:  # the body's yaw rate as the gyro would read it: its bias, which the navigation removes
            out[GYRO] += bias
    if s[PAYBACK_LEFT] > 0.0:  # a frozen gyro's owed heading, re-admitted or not (the reference goes without)
        out[GYRO] += s[PAYBACK_RATE]
        s[PAYBACK_LEFT] -= 1.0


@jitable
def body_acceleration(raw, codes, p) -> float:
    """The body's tangential acceleration from the healthy tangential accelerometers present (codes[0],
    codes[2] 0, p.analog_present): the mean of a_t1 and a_t2, else the healthy one, NaN if neither is
    (m/s^2)."""
    first_ok = codes[0] == 0 and p.analog_present[0]
    second_ok = codes[2] == 0 and p.analog_present[2]
    if first_ok and second_ok:
        return 0.5 * (raw[0] + raw[2])
    if first_ok or second_ok:
        return raw[0] if first_ok else raw[2]
    return math.nan
