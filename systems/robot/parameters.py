"""The robot's physical parameters (RobotParameters, SI units) and the two reference robots of the papers
(tinyphoon, kurt3d); PlantConstants, the numbers the plant's pure functions read."""

from __future__ import annotations

import collections
import dataclasses as dc
import functools

from slipnav.systems.ranges import require_in

GRAVITY = 9.81

PARAMETER_RANGES = {
    "mass": "(0.0, inf]",
    "yaw_inertia": "(0.0, inf]",
    "track_width": "(0.0, inf]",
    "wheel_radius": "(0.0, inf]",
    "wheel_inertia": "(0.0, inf]",
    "wheel_load_fraction": "(0.0, 1.0]",
    "tyre_friction": "(0.0, 2.0]",
    "tyre_stiffness_factor": "(0.0, inf]",
    "tyre_shape_factor": "(1.0, 2.0]",
    "slip_speed_floor": "(0.0, inf]",
    "shoe_offset": "[0.0, inf]",
    "shoe_friction": "[0.0, 2.0]",
    "shoe_viscous_drag": "[0.0, inf]",
    "shoe_slip_speed": "(0.0, inf]",
    "motor_constant": "(0.0, inf]",
    "motor_resistance": "(0.0, inf]",
    "motor_current_limit": "(0.0, inf]",
    "supply_voltage": "(0.0, inf]",
    "bearing_drag": "[0.0, inf]",
    "speed_loop_period": "(0.0, 0.1]",
    "speed_loop_kp": "[0.0, inf]",
    "speed_loop_ki": "[0.0, inf]",
    "wheel_speed_limit": "(0.0, inf]",
}
"""The allowed values of RobotParameters' fields (systems/ranges.py's notation), each also finite."""


@dc.dataclass(frozen=True)
class RobotParameters:
    """Physical parameters of a differential-drive robot (SI units).

    Args:
        name: label used in reports.
        mass: total mass (kg).
        yaw_inertia: moment of inertia about the vertical axis through the centre of gravity (kg m^2).
        track_width: full distance between the wheel contact points (Seyr's b, Indiveri's 2b) (m).
        wheel_radius: nominal wheel radius (m): the motor controller's speed loop converts the commanded
            circumferential speeds to wheel rates with it (its firmware knows only the data sheet).
        wheel_inertia: wheel + gearbox + rotor inertia reflected to the wheel shaft (kg m^2).
        wheel_load_fraction: share of the weight carried by the two wheels; the rest rests on the shoes.
        tyre_friction: peak tyre/ground friction coefficient mu.
        tyre_stiffness_factor: Pacejka B (1/unit slip).
        tyre_shape_factor: Pacejka C, in (1, 2); sliding friction is mu*sin(C*pi/2) of the peak.
        slip_speed_floor: regularising reference speed of the slip definitions (m/s).
        shoe_offset: distance of the front and rear felt shoes from the axle (m).
        shoe_friction: Coulomb coefficient of the felt shoes.
        shoe_viscous_drag: viscous drag of each shoe (N s/m).
        shoe_slip_speed: speed scale of the tanh-regularised Coulomb friction (m/s).
        motor_constant: torque constant = back-EMF constant referred to the wheel (N m/A = V s/rad).
        motor_resistance: armature resistance (ohm).
        motor_current_limit: current (hence torque) limit of the motor driver (A).
        supply_voltage: H-bridge supply, the voltage limit (V).
        bearing_drag: viscous drag of each wheel's bearings and gearbox (N m s/rad).
        speed_loop_period: sampling period of the PI wheel-speed loop (s).
        speed_loop_kp: proportional gain on the wheel angular-speed error (V s/rad).
        speed_loop_ki: integral gain (V/rad).
        wheel_speed_limit: V_m, the largest circumferential wheel speed the controller may command (m/s).
        rolling_radius_R, rolling_radius_L: the wheels' true rolling radii (m), where the tyres touch the
            ground; None: wheel_radius. A real robot's differ from the nominal by tyre wear, load and
            manufacture (Borenstein & Feng's UMBmark: unequal wheel diameters, the dominant systematic
            odometry error).
    """

    name: str
    mass: float
    yaw_inertia: float
    track_width: float
    wheel_radius: float
    wheel_inertia: float
    wheel_load_fraction: float
    tyre_friction: float
    tyre_stiffness_factor: float
    tyre_shape_factor: float
    slip_speed_floor: float
    shoe_offset: float
    shoe_friction: float
    shoe_viscous_drag: float
    shoe_slip_speed: float
    motor_constant: float
    motor_resistance: float
    motor_current_limit: float
    supply_voltage: float
    bearing_drag: float
    speed_loop_period: float
    speed_loop_kp: float
    speed_loop_ki: float
    wheel_speed_limit: float
    rolling_radius_R: float | None = None
    rolling_radius_L: float | None = None

    def __post_init__(self):
        for name, allowed in PARAMETER_RANGES.items():
            require_in(name, getattr(self, name), allowed, finite=True)
        for name in ("rolling_radius_R", "rolling_radius_L"):
            if getattr(self, name) is not None:
                require_in(name, getattr(self, name), "(0.0, inf]", finite=True)
        if self.wheel_speed_limit > self.no_load_speed:
            raise ValueError(
                f"wheel_speed_limit={self.wheel_speed_limit} exceeds the motors' no-load "
                f"circumferential speed {self.no_load_speed:.3f} m/s: allowed (0, {self.no_load_speed:.3f}]"
            )

    @property
    def radius_R(self) -> float:
        """Rolling radius of the right wheel (m)."""
        return self.wheel_radius if self.rolling_radius_R is None else self.rolling_radius_R

    @property
    def radius_L(self) -> float:
        """Rolling radius of the left wheel (m)."""
        return self.wheel_radius if self.rolling_radius_L is None else self.rolling_radius_L

    @property
    def no_load_speed(self) -> float:
        """Circumferential wheel speed at full supply voltage and zero torque (m/s)."""
        return self.wheel_radius * self.supply_voltage / self.motor_constant

    @property
    def wheel_normal_load(self) -> float:
        """Static normal force on each wheel (N)."""
        return 0.5 * self.wheel_load_fraction * self.mass * GRAVITY

    @property
    def shoe_normal_load(self) -> float:
        """Static normal force on each felt shoe (N)."""
        return 0.5 * (1.0 - self.wheel_load_fraction) * self.mass * GRAVITY

    @property
    def traction_limit_acceleration(self) -> float:
        """Largest acceleration the tyres can transmit, mu * N_wheels / m (m/s^2), shoes neglected."""
        return self.tyre_friction * self.wheel_load_fraction * GRAVITY

    def replace(self, **changes) -> RobotParameters:
        return dc.replace(self, **changes)

    @functools.cached_property
    def constants(self) -> tuple:
        """The floats the plant's arithmetic reads, in PlantConstants' order (computed once; the
        compiled plant_advance takes them as one tuple)."""
        return tuple(float(getattr(self, name)) for name in PlantConstants._fields)


PlantConstants = collections.namedtuple(
    "PlantConstants",
    "mass yaw_inertia track_width wheel_radius wheel_inertia tyre_friction tyre_stiffness_factor "
    "tyre_shape_factor slip_speed_floor shoe_offset shoe_friction shoe_viscous_drag shoe_slip_speed "
    "motor_constant motor_resistance motor_current_limit supply_voltage bearing_drag speed_loop_period "
    "speed_loop_kp speed_loop_ki radius_R radius_L wheel_normal_load shoe_normal_load",
)
"""RobotParameters' numbers as the plant's pure functions read them (``p.mass``, ``p.radius_R``, ...):
every one of them takes either."""


def tinyphoon() -> RobotParameters:
    """Seyr & Jakubek's Tinyphoon (§II): 75 mm cube, ~0.4 kg, 22.5 W/kg, ~4 m/s, rubber tyres.

    Motor figures follow a Faulhaber 2224-006SR class coreless motor (4.5 W, rotor 3.8 g cm^2) on a 3:1
    gearhead; 2 x 4.5 W / 0.4 kg = 22.5 W/kg. Yaw inertia of a uniform 75 mm square plate. The felt shoes are
    assumed to carry 20 % of the weight. The speed loop runs at 1 kHz on the DSP (assumption).
    """
    k = 6.0 / 280.0  # V s/rad at the wheel: 6 V gives 280 rad/s = 4.2 m/s no-load
    return RobotParameters(
        name="tinyphoon",
        mass=0.4,
        yaw_inertia=0.4 * 2 * 0.075**2 / 12,
        track_width=0.068,
        wheel_radius=0.015,
        wheel_inertia=3.7e-6,
        wheel_load_fraction=0.8,
        tyre_friction=0.7,
        tyre_stiffness_factor=15.0,
        tyre_shape_factor=1.3,
        slip_speed_floor=0.3,
        shoe_offset=0.03,
        shoe_friction=0.25,
        shoe_viscous_drag=0.05,
        shoe_slip_speed=0.01,
        motor_constant=k,
        motor_resistance=6.0**2 / (4 * 4.5),  # max mechanical power V^2/(4R) = 4.5 W
        motor_current_limit=1.5,
        supply_voltage=6.0,
        bearing_drag=2e-6,
        speed_loop_period=1e-3,
        speed_loop_kp=0.4,
        speed_loop_ki=40.0,
        wheel_speed_limit=4.0,
    )


def kurt3d() -> RobotParameters:
    """Indiveri et al.'s high-speed indoor Kurt3D (§IV-A): 2 x 90 W, V_m = 4.1 m/s, speed loop at 100 Hz.

    Six 16 cm wheels lumped into one wheel per side (skid steering treated as differential drive, as the
    paper does); no shoes. Mass ~22 kg and a 0.45 m x 0.4 m box for the yaw inertia (assumptions).
    """
    v_no_load = 5.0  # headroom above V_m = 4.1 m/s so that the speed loop can hold V_m
    k = 24.0 * 0.08 / v_no_load
    return RobotParameters(
        name="kurt3d",
        mass=22.0,
        yaw_inertia=22.0 * (0.45**2 + 0.4**2) / 12,
        track_width=0.4,
        wheel_radius=0.08,
        wheel_inertia=0.02,
        wheel_load_fraction=1.0,
        tyre_friction=0.8,
        tyre_stiffness_factor=12.0,
        tyre_shape_factor=1.3,
        slip_speed_floor=0.3,
        shoe_offset=0.0,
        shoe_friction=0.0,
        shoe_viscous_drag=0.0,
        shoe_slip_speed=0.01,
        motor_constant=k,
        motor_resistance=24.0**2 / (4 * 90.0),
        motor_current_limit=12.0,
        supply_voltage=24.0,
        bearing_drag=1e-3,
        speed_loop_period=1e-2,
        speed_loop_kp=6.0,
        speed_loop_ki=60.0,
        wheel_speed_limit=4.1,
    )


ROBOTS = {"tinyphoon": tinyphoon, "kurt3d": kurt3d}


def robot_parameters(name: str) -> RobotParameters:
    """The named reference robot's parameters."""
    try:
        return ROBOTS[name]()
    except KeyError:
        raise ValueError(f"robot={name!r} is unknown: allowed {sorted(ROBOTS)}") from None
