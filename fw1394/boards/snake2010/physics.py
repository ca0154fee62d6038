"""Deterministic DC motor + bridge amplifier behind one snake-board channel.

Thesis section 5.2 describes the amplifier: a bridge of two op amps on one
motor supply VM, the motor's zero at VM/2, a DAC voltage command, a DAC
current limit, and a current-sense signal whose gain is set by the digital
pot. With O1 high ("speed control") the amplified current signal is fed back
into the amplifier; with O1 low the feedback is cut. Everything numeric
below (supply, resistances, motor constant, inertia, gearing, travel) is
invented to look like a small geared surgical-robot actuator; the thesis
gives no values.

Model (documented in docs/boards/snake2010.md):

* electrical: winding inductance is neglected (its time constant is far
  below the 1 ms servo period), so the current follows the state at once;
* speed mode adds ``compensation_ohms = k_comp * G * R_sense`` of positive
  current feedback (IR compensation); once that reaches the circuit
  resistance the loop runs away and only the limits hold the current;
* limits: each op amp output stays ``headroom`` away from its supply rails,
  and the current-limit DAC caps the magnitude of the current;
* mechanical: ``J dw/dt = Kt I - b w - Tc sign(w)``: viscous plus dry
  (Coulomb) friction of the gearhead and lead screw, with stiction (a motor
  at rest starts only when its torque beats ``Tc``) and hard stops at both
  ends of the actuator's travel.

Within one direction of motion the equations are linear, so each fixed step
is integrated exactly (exponential solution) under the regime holding at its
start; a step in which friction brings the motor to rest ends at rest.
:meth:`MotorAxis.run` covers a whole span of such steps with one exponential
while the regime provably holds at every step start, which is the same motion
up to rounding (the composition of exponentials against their product).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple


@dataclass(frozen=True)
class MotorConstants:
    """Invented parameters of one amplifier channel, motor and actuator."""

    supply_volts: float = 12.0
    headroom_volts: float = 0.7
    bridge_gain: float = 8.0  # motor volts per DAC volt away from 1.25 V
    winding_ohms: float = 7.5
    sense_ohms: float = 0.5
    compensation_gain: float = 7.2  # bridge volts per volt of gained sense signal
    motor_constant: float = 0.01  # V*s/rad, equal to N*m/A
    inertia: float = 1.0e-6  # kg*m^2 at the motor shaft, gearing included
    viscous_friction: float = 1.0e-7  # N*m*s/rad, must be positive
    coulomb_friction: float = 3.0e-4  # N*m, about 6 % of the 0.5 A torque
    current_limit_full_scale_amps: float = 1.0
    encoder_counts_per_rev: int = 2048  # 512 lines, x4 quadrature decoding
    motor_revs_per_mm: float = 32.0  # 16:1 gearhead on a 0.5 mm lead screw
    travel_mm: float = 20.0  # the pot spans 0..2.5 V over this travel
    runaway_fraction: float = 0.05  # below this share of R the loop runs away

    def __post_init__(self) -> None:
        if self.viscous_friction <= 0 or self.inertia <= 0:
            raise ValueError("inertia and viscous friction must be positive")
        if self.coulomb_friction < 0:
            raise ValueError("coulomb friction cannot be negative")

    @property
    def circuit_ohms(self) -> float:
        """Resistance of the whole motor loop, sense resistor included."""
        return self.winding_ohms + self.sense_ohms

    @property
    def max_motor_volts(self) -> float:
        """Largest voltage the bridge can put across the motor."""
        return self.supply_volts - 2.0 * self.headroom_volts

    @property
    def half_travel_rad(self) -> float:
        """Motor angle from mid-travel to either hard stop."""
        return self.travel_mm / 2.0 * self.motor_revs_per_mm * 2.0 * math.pi


class Drive(NamedTuple):
    """Amplifier inputs; they change only when a register is written.

    A named tuple rather than a dataclass: the physics reads its fields on every
    step, and tuple fields are the cheapest attribute reads Python has.
    """

    powered: bool
    bridge_volts: float = 0.0  # what the command alone asks across the motor
    current_limit_amps: float = 0.0
    compensation_ohms: float = 0.0  # 0 in torque mode


UNPOWERED = Drive(powered=False)

#: (1/time constant, final speed, current, which branch of the amplifier model).
Regime = tuple[float, float, float, int]
#: The branches: each holds on one interval of speeds (its conditions are linear in it).
_COASTING, _LINEAR, _HIGH_RAIL, _HIGH_LIMIT, _LOW_RAIL, _LOW_LIMIT = range(6)


class MotorAxis:
    """State and exact fixed-step integration of one motor and its actuator."""

    def __init__(self, constants: MotorConstants) -> None:
        self.constants = constants
        self.angle_rad = 0.0  # 0 = mid-travel, the pot reads 1.25 V
        self.velocity_rad_s = 0.0
        self.lowest_angle_rad = 0.0  # excursion since the last encoder preload
        self.highest_angle_rad = 0.0
        self.last_direction = 0  # sign of the latest motion, 0 = never moved
        # Plain attributes: the step loop is the emulator's hot path.
        self._stop = constants.half_travel_rad
        self._mid_travel_mm = constants.travel_mm / 2.0
        self._rad_per_mm = 2.0 * math.pi * constants.motor_revs_per_mm
        self._ke = constants.motor_constant
        self._kt_ke = constants.motor_constant**2
        self._ohms = constants.circuit_ohms
        self._rail = constants.max_motor_volts
        self._friction = constants.viscous_friction
        self._coulomb = constants.coulomb_friction
        self._inertia = constants.inertia
        self._runaway_ohms = constants.runaway_fraction * constants.circuit_ohms
        self._free_rate = self._friction / self._inertia  # no current: friction alone
        rail_damping = self._friction + self._kt_ke / self._ohms
        self._rail_rate = rail_damping / self._inertia
        self._high_rail_speed = self._ke * self._rail / self._ohms / rail_damping
        self._low_rail_speed = self._ke * -self._rail / self._ohms / rail_damping
        # The latest regime decided and what for: the words read after a span ask
        # again for its end speed, and so does the next span if the drive held.
        self._known: Regime = (self._free_rate, 0.0, 0.0, _COASTING)
        self._known_drive = UNPOWERED
        self._known_speed: float | None = None

    @property
    def position_mm(self) -> float:
        """Actuator position, 0 at one hard stop, ``travel_mm`` at the other."""
        return self._mid_travel_mm + self.angle_rad / self._rad_per_mm

    def current_amps(self, drive: Drive) -> float:
        """Motor current for the present speed and ``drive``."""
        return self._regime(drive, self.velocity_rad_s)[2]

    def held(self, drive: Drive) -> bool:
        """True if the motor is at rest and stays there under ``drive``.

        Unpowered, or its torque does not beat the dry friction (stiction):
        :meth:`run` and :meth:`advance` would leave it exactly as it is.
        """
        w = self.velocity_rad_s
        return w == 0.0 and abs(self._ke * self._regime(drive, w)[2]) <= self._coulomb

    def reset_excursion(self) -> None:
        """Forget the travel seen so far (the encoder was preloaded)."""
        self.lowest_angle_rad = self.highest_angle_rad = self.angle_rad

    def advance(self, seconds: float, drive: Drive) -> None:
        """Integrate ``seconds`` of motion with ``drive`` held constant."""
        w0 = self.velocity_rad_s
        if w0 == 0.0 and not drive.powered:
            return  # idle axes cost nothing, which keeps big buses cheap
        rate, w_drive, amps, _ = self._regime(drive, w0)
        if w0 == 0.0:
            torque = self._ke * amps
            if abs(torque) <= self._coulomb:
                return  # stiction holds the motor
            direction = 1.0 if torque > 0 else -1.0
        else:
            direction = 1.0 if w0 > 0 else -1.0
        # Dry friction opposes the motion: a constant shift of the final speed.
        w_final = w_drive - direction * self._coulomb / (self._inertia * rate)
        if w_final * direction < 0.0:
            # The motor decelerates through zero unless the step ends first.
            to_rest = math.log1p(w0 / -w_final) / rate
            if to_rest < seconds:
                self._move(to_rest, rate, w0, w_final)
                self.velocity_rad_s = 0.0
                return
        self._move(seconds, rate, w0, w_final)

    def run(self, start: int, target: int, step: int, ticks_per_second: int, drive: Drive) -> None:
        """Move from tick ``start`` to ``target`` as :meth:`advance` per step of a fixed grid would.

        The reference takes one :meth:`advance` per ``step`` ticks of the absolute
        grid (the first and last steps cut at ``start`` and ``target``). While the
        regime chosen at the first step start holds at every later one, the
        steps compose into one exponential, so the whole rest of the span is
        tried at once; where it may not hold, one reference step is taken.
        """
        now = start
        while now < target:
            if self._jump((target - now) / ticks_per_second, drive):
                return
            nxt = min((now // step + 1) * step, target)
            self.advance((nxt - now) / ticks_per_second, drive)
            now = nxt

    def _jump(self, seconds: float, drive: Drive) -> bool:
        """Move ``seconds`` at once if every step start would choose the same regime.

        The regime depends on the speed alone, each regime holds on an interval
        of speeds, and within one regime the speed moves monotonically; so the
        regime at the span's end speed equal to the one at its start proves it
        for every speed between. A span in which the motor comes to rest or
        reaches a hard stop is declined (False, nothing changed): the
        reference ends such a step early.
        """
        w0 = self.velocity_rad_s
        if w0 == 0.0 and not drive.powered:
            return True
        rate, w_drive, amps, regime = self._regime(drive, w0)
        if w0 == 0.0:
            torque = self._ke * amps
            if abs(torque) <= self._coulomb:
                return True  # stiction holds now, so at every later step start too
            direction = 1.0 if torque > 0 else -1.0
        else:
            direction = 1.0 if w0 > 0 else -1.0
        w_final = w_drive - direction * self._coulomb / (self._inertia * rate)
        if w_final * direction < 0.0 and math.log1p(w0 / -w_final) / rate < seconds:
            return False
        angle, w1 = self._solution(seconds, rate, w0, w_final)
        if angle > self._stop or angle < -self._stop or self._regime(drive, w1)[3] != regime:
            return False
        self._land(angle, w1)
        return True

    def _move(self, seconds: float, rate: float, w0: float, w_final: float) -> None:
        angle, w1 = self._solution(seconds, rate, w0, w_final)
        if angle > self._stop or angle < -self._stop:
            angle = math.copysign(self._stop, angle)
            w1 = 0.0  # the hard stop absorbs the motion
        self._land(angle, w1)

    def _solution(
        self, seconds: float, rate: float, w0: float, w_final: float
    ) -> tuple[float, float]:
        """(angle, speed) after ``seconds`` of dw/dt = rate * (w_final - w), exactly."""
        gone = -math.expm1(-rate * seconds)  # 1 - exp(-x) without cancellation
        w1 = w_final + (w0 - w_final) * (1.0 - gone)
        return self.angle_rad + w_final * seconds + (w0 - w_final) * gone / rate, w1

    def _land(self, angle: float, w1: float) -> None:
        self.angle_rad = angle
        self.velocity_rad_s = w1
        if w1 != 0.0:
            self.last_direction = 1 if w1 > 0 else -1
        if angle < self.lowest_angle_rad:
            self.lowest_angle_rad = angle
        elif angle > self.highest_angle_rad:
            self.highest_angle_rad = angle

    def _regime(self, drive: Drive, w: float) -> Regime:
        """(1/time constant, final speed, current, which regime) at speed ``w``.

        The motion obeys ``dw/dt = rate * (w_final - w)`` until the regime
        changes; which regime holds depends on the speed. The latest answer is
        kept and matched by identity: drive and speed are immutable, so the
        same objects give the same answer.
        """
        if w is self._known_speed and drive is self._known_drive:
            return self._known
        regime: Regime
        powered, bridge, limit, compensation = drive
        if not powered:
            regime = (self._free_rate, 0.0, 0.0, _COASTING)
        else:
            emf = self._ke * w
            ohms = self._ohms
            effective = ohms - compensation
            if effective > self._runaway_ohms:
                wanted = (bridge - emf) / effective
            else:
                # Over-compensated: the positive feedback drives the current to
                # whichever limit lies in the direction the command pushes.
                push = bridge - emf
                if push == 0.0:
                    push = bridge
                wanted = math.copysign(math.inf, push) if push else 0.0
            rail = self._rail
            high_rail, low_rail = (rail - emf) / ohms, (-rail - emf) / ohms
            # Fixed current: only friction opposes the constant torque. Fixed
            # voltage: I = (V - Ke w) / R, and the back EMF makes the speed settle.
            if wanted > high_rail or wanted > limit:
                if high_rail < limit:
                    regime = (self._rail_rate, self._high_rail_speed, high_rail, _HIGH_RAIL)
                else:
                    speed = self._ke * limit / self._friction
                    regime = (self._free_rate, speed, limit, _HIGH_LIMIT)
            elif wanted < low_rail or wanted < -limit:
                if low_rail > -limit:
                    regime = (self._rail_rate, self._low_rail_speed, low_rail, _LOW_RAIL)
                else:
                    speed = self._ke * -limit / self._friction
                    regime = (self._free_rate, speed, -limit, _LOW_LIMIT)
            else:
                damping = self._friction + self._kt_ke / effective
                speed = self._ke * bridge / effective / damping
                regime = (damping / self._inertia, speed, wanted, _LINEAR)
        self._known, self._known_drive, self._known_speed = regime, drive, w
        return regime
