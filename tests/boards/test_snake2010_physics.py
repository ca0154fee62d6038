"""A motor run over a whole span equals the fixed-step reference, up to rounding.

The reference is the board's original integration: one :meth:`MotorAxis.advance`
per step of the absolute grid, the regime chosen anew at every step start.
:meth:`MotorAxis.run` covers the span with as few exponentials as the regime
allows. The two differ only in how the exponential solution is composed
(``exp(-r a) exp(-r b)`` against ``exp(-r (a + b))``), a few units in the last
place per step: a relative 1e-9 bounds that for the spans drawn here (at most a
few thousand steps). An absolute 1e-9 rad (a millionth of an encoder count)
covers states near zero.

Two shortcuts of the board's must change nothing at all: the regime a motor
keeps from its latest decision (against a motor that decides afresh every
time), and skipping a motor that is held at rest.
"""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.physics import UNPOWERED, Drive, MotorAxis, MotorConstants, Regime
from fw1394.engine.space import TICKS_PER_SECOND

CONSTANTS = MotorConstants()
STOP = CONSTANTS.half_travel_rad
STEP = 12_288  # the board's default grid, 0.25 ms
TOLERANCE = {"rel_tol": 1e-9, "abs_tol": 1e-9}

drives = st.one_of(
    st.just(UNPOWERED),
    st.builds(
        Drive,
        st.just(True),
        st.floats(-13.0, 13.0),
        st.floats(0.0, 1.0),
        st.one_of(st.just(0.0), st.floats(0.0, 8.0, exclude_max=True)),  # 8 = the circuit: R 0
    ),
)
states = st.tuples(
    st.floats(-STOP, STOP),  # angle
    st.one_of(st.just(0.0), st.floats(-3000.0, 3000.0)),  # velocity
    st.sampled_from([-1, 0, 1]),  # last direction
)


def _motor(state: tuple[float, float, int], kind: type[MotorAxis] = MotorAxis) -> MotorAxis:
    motor = kind(CONSTANTS)
    motor.angle_rad, motor.velocity_rad_s, motor.last_direction = state
    motor.lowest_angle_rad = motor.highest_angle_rad = motor.angle_rad
    return motor


def _reference(motor: MotorAxis, start: int, target: int, drive: Drive) -> None:
    now = start
    while now < target:
        nxt = min((now // STEP + 1) * STEP, target)
        motor.advance((nxt - now) / TICKS_PER_SECOND, drive)
        now = nxt


@settings(max_examples=400, deadline=None)
@given(
    state=states,
    segments=st.lists(
        st.tuples(drives, st.integers(0, 4 * STEP), st.integers(0, 40 * STEP)), max_size=6
    ),
)
def test_run_matches_the_fixed_step_reference(
    state: tuple[float, float, int], segments: list[tuple[Drive, int, int]]
) -> None:
    fast, reference = _motor(state), _motor(state)
    now = 0
    for drive, offset, span in segments:
        start, now = now + offset, now + offset + span
        fast.run(start, now, STEP, TICKS_PER_SECOND, drive)
        _reference(reference, start, now, drive)
        for name in ("angle_rad", "velocity_rad_s", "lowest_angle_rad", "highest_angle_rad"):
            got, want = getattr(fast, name), getattr(reference, name)
            assert math.isclose(got, want, **TOLERANCE), (name, got, want)
        assert fast.last_direction == reference.last_direction


def test_a_steady_regime_takes_one_exponential_per_span() -> None:
    # The point of run(): a servoed motor costs one step per request, not one per grid step.
    motor = _motor((0.0, 400.0, 1))
    drive = Drive(True, 4.0, 1.0, 0.0)
    motor.run(0, STEP, STEP, TICKS_PER_SECOND, drive)  # settle into the linear regime
    calls = 0
    advance = motor.advance

    def counting(seconds: float, drive: Drive) -> None:
        nonlocal calls
        calls += 1
        advance(seconds, drive)

    motor.advance = counting  # type: ignore[method-assign]
    motor.run(STEP + 5, 40 * STEP + 7, STEP, TICKS_PER_SECOND, drive)
    assert calls == 0


class Forgetful(MotorAxis):
    """The board's motor with its kept regime defeated: every question decided afresh."""

    def _regime(self, drive: Drive, w: float) -> Regime:
        self._known_speed = None
        return super()._regime(drive, w)


def _state(motor: MotorAxis) -> tuple[float | int, ...]:
    return (
        motor.angle_rad,
        motor.velocity_rad_s,
        motor.lowest_angle_rad,
        motor.highest_angle_rad,
        motor.last_direction,
    )


@settings(max_examples=300, deadline=None)
@given(
    state=states,
    segments=st.lists(
        st.tuples(
            drives,
            st.booleans(),  # the same drive object again, as between two register writes
            st.integers(0, 4 * STEP),
            st.integers(0, 40 * STEP),
        ),
        max_size=8,
    ),
)
def test_the_kept_regime_changes_nothing(
    state: tuple[float, float, int], segments: list[tuple[Drive, bool, int, int]]
) -> None:
    # Exactly, not up to rounding: the same motion, the same current afterwards.
    kept, fresh = _motor(state), _motor(state, Forgetful)
    now, drive = 0, UNPOWERED
    for new_drive, same, offset, span in segments:
        if not same:
            drive = new_drive
        start, now = now + offset, now + offset + span
        kept.run(start, now, STEP, TICKS_PER_SECOND, drive)
        fresh.run(start, now, STEP, TICKS_PER_SECOND, drive)
        assert _state(kept) == _state(fresh)
        assert kept.current_amps(drive) == fresh.current_amps(drive)
        assert kept.current_amps(new_drive) == fresh.current_amps(new_drive)


@settings(max_examples=300, deadline=None)
@given(
    state=states,
    drive=drives,
    start=st.integers(0, 4 * STEP),
    span=st.integers(1, 40 * STEP),
)
def test_held_means_a_span_leaves_the_motor_as_it_is(
    state: tuple[float, float, int], drive: Drive, start: int, span: int
) -> None:
    # The board skips held motors and keeps their words, so "held" must mean that; and
    # away from the hard stops (which hold a motor pushing into them) nothing else is.
    motor = _motor(state)
    before = _state(motor)
    held = motor.held(drive)
    motor.run(start, start + span, STEP, TICKS_PER_SECOND, drive)
    if held or abs(state[0]) < STOP:
        assert held == (_state(motor) == before)


# The DC motor the board models, written here from its equations rather than
# taken from MotorAxis: J dw/dt = Kt I - b w - Tc (for w > 0), with Kt = Ke and
# the loop current I = (V - Ke w) / (R - Rc), Rc the current compensation.


def test_a_motor_at_the_voltage_rail_settles_at_the_dc_motor_speed() -> None:
    # At the rail V the steady state of the equations is
    # w = (Ke V / R - Tc) / (b + Ke^2 / R); 0.9 s is over ten time constants.
    motor = _motor((-STOP / 2, 0.0, 0))
    motor.run(0, int(0.9 * TICKS_PER_SECOND), STEP, TICKS_PER_SECOND, Drive(True, 13.0, 1.0, 0.0))
    ke, ohms = CONSTANTS.motor_constant, CONSTANTS.circuit_ohms
    volts, tc, b = CONSTANTS.max_motor_volts, CONSTANTS.coulomb_friction, CONSTANTS.viscous_friction
    steady = (ke * volts / ohms - tc) / (b + ke * ke / ohms)
    assert math.isclose(motor.velocity_rad_s, steady, rel_tol=1e-4)


def test_an_over_compensated_loop_drives_the_current_to_the_limit_against_the_back_emf() -> None:
    # Rc close to R: I = (V - Ke w) / (R - Rc) runs to the limit in the sign of
    # V - Ke w. At 1000 rad/s the back EMF (10 V) beats a 2 V command, so the
    # current is -limit and the motor brakes at (Kt limit + b w + Tc) / J.
    motor = _motor((0.0, 1000.0, 1))
    limit, seconds = 0.5, 0.001
    motor.run(
        0, int(seconds * TICKS_PER_SECOND), STEP, TICKS_PER_SECOND, Drive(True, 2.0, limit, 7.9)
    )
    braking = (
        CONSTANTS.motor_constant * limit
        + CONSTANTS.viscous_friction * 1000.0
        + CONSTANTS.coulomb_friction
    ) / CONSTANTS.inertia
    assert math.isclose(motor.velocity_rad_s, 1000.0 - braking * seconds, rel_tol=1e-5)
