"""Sensor faults injected between the sensors and the navigation, as timed events (scenario data).

A ``FaultEvent`` acts on one sensor channel from ``start`` for ``duration`` seconds, on what the
navigation reads at t_k (start <= t_k < start + duration):

=============  =========================================================================================
kind           the channel reads
=============  =========================================================================================
``nan``        NaN
``inf``        +inf
``dropout``    the value it read just before the fault (frozen)
``stuck``      the same, for an encoder (a stuck counter; it resumes with the true count)
``bias``       the reading plus ``value`` (rad/s, m/s^2; encoder counts)
``scale``      the reading times 1 + ``value`` (-2: the sign flipped); an encoder counts 1 + ``value``
               times its increments
``spike``      the reading plus ``value`` at the one sample start <= t_k < start + T_N (duration unused)
``saturation`` the reading clipped to +-``value`` (``value`` > 0, the channel's units)
=============  =========================================================================================

Channels: ``accel1_t accel1_n accel2_t accel2_n gyro encoder_R encoder_L`` (the order of the sample
vector [accelerometers (4), gyro, encoders (2)]). Several events may overlap; they apply in list order.

Perturbations of the plant (Indiveri et al. Fig. 5), on ``wheel_R``, ``wheel_L`` or the ``body``, act on
the simulated robot through its ``disturbance`` input (systems/robot/plant.py):

=================  ======================================================================================
``wheel_lifted``   the wheel loses ground contact: no tyre force (it spins freely on its motor)
``wheel_held``     a hand stops the wheel (a brake of time constant dynamics.HOLD_TIME_CONSTANT)
``wheel_pushed``   a hand turns the wheel with ``value`` N m more torque
``body_push``      a push of ``value`` N on the body, along its heading (``body_t``) or to its left
                   (``body_n``)
=================  ======================================================================================
"""

import dataclasses as dc
import math

import numpy as np
from pydrake.systems.framework import LeafSystem
from slipnav.systems.ranges import require_in
from slipnav.systems.robot.contact import NO_DISTURBANCE

SENSOR_CHANNELS = ("accel1_t", "accel1_n", "accel2_t", "accel2_n", "gyro", "encoder_R", "encoder_L")
ENCODER_CHANNELS = ("encoder_R", "encoder_L")
SENSOR_FAULT_KINDS = ("nan", "inf", "dropout", "stuck", "bias", "ramp", "scale", "spike", "saturation")
PLANT_EVENT_KINDS = ("wheel_lifted", "wheel_held", "wheel_pushed", "body_push")
WHEEL_CHANNELS = ("wheel_R", "wheel_L")
BODY_CHANNELS = ("body_t", "body_n")

MAX_FAULT_TIME = 3600.0


@dc.dataclass
class FaultEvent:
    """One timed sensor fault or plant perturbation (module docstring).

    Args:
        kind: a sensor fault: nan, inf, dropout, stuck (encoders), bias, ramp (analog channels: a bias
            growing at ``value`` per second from the start), scale, spike or saturation; a
            perturbation: wheel_lifted, wheel_held, wheel_pushed or body_push.
        channel: a sensor: accel1_t, accel1_n, accel2_t, accel2_n, gyro, encoder_R or encoder_L; a wheel
            (wheel_R, wheel_L) or the body (body_t, body_n) for a perturbation.
        start: first time the navigation reads the faulty channel (s), in [0, 3600].
        duration: how long (s), in (0, 3600]; unused by ``spike``.
        value: the bias (rad/s, m/s^2, encoder counts), the ramp's rate (rad/s^2, m/s^3), relative
            scale change (-2 flips the sign), spike or saturation level (> 0), the hand's torque (N m)
            or the push (N); unused by nan, inf, dropout, stuck, wheel_lifted and wheel_held.
    """

    kind: str = "nan"
    channel: str = "gyro"
    start: float = 0.0
    duration: float = 0.5
    value: float = 0.0

    def __post_init__(self):
        kinds = SENSOR_FAULT_KINDS + PLANT_EVENT_KINDS
        if self.kind not in kinds:
            raise ValueError(f"kind={self.kind!r} is unknown: allowed {list(kinds)}")
        if self.kind in PLANT_EVENT_KINDS:
            allowed = BODY_CHANNELS if self.kind == "body_push" else WHEEL_CHANNELS
        else:
            allowed = SENSOR_CHANNELS
        if self.channel not in allowed:
            raise ValueError(
                f"channel={self.channel!r} is unknown for kind {self.kind!r}: allowed {list(allowed)}"
            )
        if self.kind == "stuck" and self.channel not in ENCODER_CHANNELS:
            raise ValueError(
                f"channel={self.channel!r} cannot be 'stuck': allowed {list(ENCODER_CHANNELS)} "
                "(a frozen analog channel is a 'dropout')"
            )
        if self.kind == "ramp" and self.channel in ENCODER_CHANNELS:
            raise ValueError(
                f"channel={self.channel!r} cannot 'ramp': allowed {list(SENSOR_CHANNELS[:5])} "
                "(an encoder's growing error is a 'scale')"
            )
        _require("start", self.start, 0.0, MAX_FAULT_TIME, closed_low=True)
        _require("duration", self.duration, 0.0, MAX_FAULT_TIME, closed_low=False)
        if self.kind == "saturation":
            _require("value", self.value, 0.0, math.inf, closed_low=False)
        else:
            _require("value", self.value, -math.inf, math.inf, closed_low=True)

    @property
    def is_sensor_fault(self) -> bool:
        return self.kind in SENSOR_FAULT_KINDS

    @property
    def index(self) -> int:
        return SENSOR_CHANNELS.index(self.channel)

    def active(self, t: float, T_N: float) -> bool:
        """Does the fault act on the sample the navigation reads at t?"""
        end = self.start + (T_N if self.kind == "spike" else self.duration)
        return self.start - 1e-9 <= t < end - 1e-9


def _require(name: str, value, low: float, high: float, closed_low: bool) -> None:
    """A finite ``value`` in [low, high] (``closed_low``), else in (low, high]."""
    bracket = "[" if closed_low else "("
    require_in(f"fault {name}", value, f"{bracket}{low:g}, {high:g}]", finite=True)


def check_fault_events(events, where: str = "faults") -> tuple:
    """The events as a tuple of validated FaultEvents (ValueError naming ``where[i]``)."""
    if events is None:
        return ()
    out = []
    for i, event in enumerate(events):
        if not isinstance(event, FaultEvent):
            raise ValueError(f"{where}[{i}]={event!r} must be a FaultEvent")
        try:
            event.__post_init__()
        except ValueError as e:
            raise ValueError(f"{where}[{i}]: {e}") from None
        out.append(event)
    return tuple(out)


def apply_sensor_faults(t: float, raw, held, previous_raw, events, T_N: float, encoder_step: float) -> list:
    """The sample [a_t1, a_n1, a_t2, a_n2, omega, theta_R, theta_L] the navigation reads at t.

    Args:
        raw: the sensors' sample. held: what the navigation read at the previous sample (dropout, stuck,
            an encoder's scale). previous_raw: the sensors' previous sample (an encoder's scale).
        events: FaultEvents. encoder_step: rad per encoder count (an encoder bias or spike is in counts).
    """
    out = [float(v) for v in raw]
    for e in events:
        if not e.is_sensor_fault or not e.active(t, T_N):
            continue
        i = e.index
        counts = encoder_step if i >= 5 else 1.0
        if e.kind == "nan":
            out[i] = math.nan
        elif e.kind == "inf":
            out[i] = math.inf
        elif e.kind in ("dropout", "stuck"):
            out[i] = float(held[i])
        elif e.kind in ("bias", "spike"):
            out[i] += e.value * counts
        elif e.kind == "ramp":
            out[i] += e.value * (t - e.start)
        elif e.kind == "scale" and i >= 5:
            out[i] = float(held[i]) + (1.0 + e.value) * (out[i] - float(previous_raw[i]))
        elif e.kind == "scale":
            out[i] *= 1.0 + e.value
        else:  # saturation
            out[i] = min(max(out[i], -e.value), e.value)
    return out


class SensorFaultInjector(LeafSystem):
    """Timed sensor faults between the sensors and the navigation (module docstring).

    .. pydrake_system::

        name: SensorFaultInjector
        input_ports:
        - accelerometers
        - gyro
        - encoders
        output_ports:
        - accelerometers
        - gyro
        - encoders

    - inputs: the sensors' samples; outputs: the samples with the active faults applied at the context's
      time (direct feedthrough).

    Update every T_N: remember the output (the value a dropout or a stuck encoder freezes) and the input.

    Args:
        events: FaultEvents. T_N: navigation period (s). encoder_step: rad per encoder count.
        initial: the sample the navigation reads before t = 0 (default: the sensors' first).
    """

    def __init__(self, events, T_N: float, encoder_step: float, initial=None):
        super().__init__()
        self._events = check_fault_events(events)
        self._T_N, self._step = T_N, encoder_step
        self._inputs = [
            self.DeclareVectorInputPort(name, size)
            for name, size in (("accelerometers", 4), ("gyro", 1), ("encoders", 2))
        ]
        held0 = np.full(7, np.nan) if initial is None else np.asarray(initial, float)
        self._held = self.DeclareDiscreteState(held0)
        self._previous = self.DeclareDiscreteState(held0.copy())
        prereq = {self.time_ticket(), self.xd_ticket()} | {port.ticket() for port in self._inputs}
        self._sample = self.DeclareVectorOutputPort("sample", 7, self._calc, prerequisites_of_calc=prereq)
        for name, cols in (("accelerometers", slice(0, 4)), ("gyro", slice(4, 5)), ("encoders", slice(5, 7))):
            self.DeclareVectorOutputPort(
                name,
                cols.stop - cols.start,
                lambda c, o, cols=cols: o.SetFromVector(self._sample.Eval(c)[cols]),
                prerequisites_of_calc=prereq,
            )
        self.DeclarePeriodicDiscreteUpdateEvent(T_N, 0.0, self._update)

    def _calc(self, context, output):
        raw = np.concatenate([port.Eval(context) for port in self._inputs])
        held = context.get_discrete_state(self._held).get_value()
        held = np.where(np.isnan(held), raw, held)
        previous = context.get_discrete_state(self._previous).get_value()
        previous = np.where(np.isnan(previous), raw, previous)
        output.SetFromVector(
            apply_sensor_faults(context.get_time(), raw, held, previous, self._events, self._T_N, self._step)
        )

    def _update(self, context, discrete_state):
        discrete_state.set_value(self._held, self._sample.Eval(context))
        discrete_state.set_value(
            self._previous, np.concatenate([port.Eval(context) for port in self._inputs])
        )


def plant_disturbance(t: float, events, T_N: float) -> tuple:
    """The plant's disturbance input at t (NO_DISTURBANCE's layout) from the active perturbations."""
    d = list(NO_DISTURBANCE)
    for e in events:
        if e.is_sensor_fault or not e.active(t, T_N):
            continue
        if e.kind == "body_push":
            d[6 + BODY_CHANNELS.index(e.channel)] += e.value
            continue
        w = WHEEL_CHANNELS.index(e.channel)
        if e.kind == "wheel_lifted":
            d[w] = 0.0
        elif e.kind == "wheel_held":
            d[2 + w] = 1.0
        else:
            d[4 + w] += e.value
    return tuple(d)


def has_plant_events(events) -> bool:
    return any(not e.is_sensor_fault for e in events)


def has_sensor_faults(events) -> bool:
    return any(e.is_sensor_fault for e in events)


class PlantDisturbance(LeafSystem):
    """The plant perturbations as the plant's disturbance input (module docstring; plant_disturbance).

    .. pydrake_system::

        name: PlantDisturbance
        output_ports:
        - disturbance

    - disturbance: [contact_R, contact_L, held_R, held_L, torque_R, torque_L, force_t, force_n] at the
      context's time (NO_DISTURBANCE when nothing acts).

    Args:
        events: FaultEvents (the sensor faults among them are ignored). T_N: period (s).
    """

    def __init__(self, events, T_N: float):
        super().__init__()
        self._events, self._T_N = check_fault_events(events), T_N
        self.DeclareVectorOutputPort(
            "disturbance",
            len(NO_DISTURBANCE),
            lambda c, o: o.SetFromVector(plant_disturbance(c.get_time(), self._events, self._T_N)),
            prerequisites_of_calc={self.time_ticket()},
        )
