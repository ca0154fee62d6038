"""Keys of the live view and what they do to the boards.

:func:`command_for_key` maps a key code (as ``curses.getch`` returns it) to
a :class:`Command`; :class:`Controller` keeps the selection and carries
commands out through the host library. The controller remembers which
amplifiers it switched on and which motor commands it changed, so that
:meth:`Controller.shutdown` can undo exactly those and leave anything
another host enabled alone.
"""

from __future__ import annotations

import curses
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum

from fw1394.boards.snake2010.spec import DAC_MAX, DAC_MIDPOINT
from fw1394.watch.sampler import BOARD_ERRORS, WatchedBoard

#: Motor-command change per +/- press: 256 codes = 9.8 mV of DAC, 78 mV at the motor.
DEFAULT_DAC_STEP = 256


class Action(StrEnum):
    """What a key press asks the watch view to do."""

    QUIT = "quit"
    NEXT_AXIS = "next axis"
    PREVIOUS_AXIS = "previous axis"
    NEXT_BOARD = "next board"
    PREVIOUS_BOARD = "previous board"
    CHANNEL = "channel"  # select channel ``Command.number`` of the current board
    ENABLE = "enable"
    DISABLE = "disable"
    ENABLE_ALL = "enable all"
    DISABLE_ALL = "disable all"
    DAC_UP = "dac up"
    DAC_DOWN = "dac down"
    DAC_ZERO = "dac zero"
    READ_POT = "read pot"


@dataclass(frozen=True)
class Command:
    """An action with its number, for the actions that take one (the channel to select)."""

    action: Action
    number: int = 0


_KEYS: dict[int, Action] = {
    ord("q"): Action.QUIT,
    ord("Q"): Action.QUIT,
    curses.KEY_DOWN: Action.NEXT_AXIS,
    ord("j"): Action.NEXT_AXIS,
    curses.KEY_UP: Action.PREVIOUS_AXIS,
    ord("k"): Action.PREVIOUS_AXIS,
    curses.KEY_RIGHT: Action.NEXT_BOARD,
    ord("\t"): Action.NEXT_BOARD,
    curses.KEY_LEFT: Action.PREVIOUS_BOARD,
    curses.KEY_BTAB: Action.PREVIOUS_BOARD,
    ord("e"): Action.ENABLE,
    ord("d"): Action.DISABLE,
    ord("E"): Action.ENABLE_ALL,
    ord("D"): Action.DISABLE_ALL,
    ord("+"): Action.DAC_UP,
    ord("="): Action.DAC_UP,  # "+" without shift on most layouts
    ord("-"): Action.DAC_DOWN,
    ord("0"): Action.DAC_ZERO,
    ord("r"): Action.READ_POT,
}

KEY_HELP = (
    "keys: arrows/tab/1-7 select  e/d enable/disable  E/D all  "
    "+/- motor command  0 stop  r read pots  q quit"
)


def command_for_key(key: int) -> Command | None:
    """The command of ``key``; None for keys without one (the screen is redrawn)."""
    if ord("1") <= key <= ord("9"):
        return Command(Action.CHANNEL, key - ord("0"))
    action = _KEYS.get(key)
    return None if action is None else Command(action)


class Controller:
    """Selection, commands and their undo for the boards of one live view."""

    def __init__(
        self,
        boards: Sequence[WatchedBoard],
        dac_step: int = DEFAULT_DAC_STEP,
        read_only: bool = False,
    ) -> None:
        if not boards:
            raise ValueError("nothing to watch")
        self.boards = list(boards)
        self.dac_step = dac_step
        self.read_only = read_only
        self.board_index = 0
        self.axis = 0
        self.message = ""
        #: (board index, axis) of amplifiers this view switched on and has not switched off.
        self.enabled_here: set[tuple[int, int]] = set()
        #: (board index, axis) whose motor command this view changed from the stop code.
        self.commanded_here: set[tuple[int, int]] = set()

    @property
    def selected(self) -> tuple[int, int]:
        return self.board_index, self.axis

    @property
    def current(self) -> WatchedBoard:
        return self.boards[self.board_index]

    # --- refresh ----------------------------------------------------------------
    def refresh(self) -> None:
        """Sample every board; feed the watchdog of boards whose amplifiers we hold.

        While this view keeps amplifiers on it is the board's controller, and
        a controller writes every cycle (thesis 6.3): the empty real-time write
        block carries no command, it only restarts the watchdog.
        """
        for index, watched in enumerate(self.boards):
            if any(board == index for board, _ in self.enabled_here):
                try:
                    watched.board.apply_all_outputs()
                except BOARD_ERRORS as error:
                    watched.problem = f"watchdog feed failed: {error}"
                    continue
            watched.refresh()

    # --- commands ---------------------------------------------------------------
    def handle(self, command: Command) -> bool:
        """Carry out ``command``; False when the view should end."""
        action = command.action
        if action is Action.QUIT:
            return False
        if self._select(command):
            return True
        if self.read_only:
            self.message = f"read-only view: '{action}' not sent"
            return True
        try:
            self._act(action)
        except BOARD_ERRORS as error:
            self.message = f"node {self.current.node}: {action} failed: {error}"
        return True

    def _select(self, command: Command) -> bool:
        action = command.action
        if action is Action.NEXT_AXIS:
            self._step_axis(+1)
        elif action is Action.PREVIOUS_AXIS:
            self._step_axis(-1)
        elif action is Action.NEXT_BOARD:
            self._step_board(+1)
        elif action is Action.PREVIOUS_BOARD:
            self._step_board(-1)
        elif action is Action.CHANNEL:
            if 1 <= command.number <= self.current.channels:
                self.axis = command.number - 1
            else:
                self.message = f"node {self.current.node} has no channel {command.number}"
        else:
            return False
        return True

    def _step_axis(self, step: int) -> None:
        # Up and down run through the channels of every board in turn, as one list.
        rows = [(b, a) for b, w in enumerate(self.boards) for a in range(w.channels)]
        position = rows.index(self.selected)
        self.board_index, self.axis = rows[(position + step) % len(rows)]

    def _step_board(self, step: int) -> None:
        self.board_index = (self.board_index + step) % len(self.boards)
        self.axis = min(self.axis, self.current.channels - 1)

    def _act(self, action: Action) -> None:
        if action is Action.ENABLE:
            self._power([(self.board_index, self.axis)], on=True)
        elif action is Action.DISABLE:
            self._power([(self.board_index, self.axis)], on=False)
        elif action in (Action.ENABLE_ALL, Action.DISABLE_ALL):
            everything = [(b, a) for b, w in enumerate(self.boards) for a in range(w.channels)]
            self._power(everything, on=action is Action.ENABLE_ALL)
        elif action is Action.DAC_UP:
            self._command(self._present_dac() + self.dac_step)
        elif action is Action.DAC_DOWN:
            self._command(self._present_dac() - self.dac_step)
        elif action is Action.DAC_ZERO:
            self._command(DAC_MIDPOINT)
        elif action is Action.READ_POT:
            self.current.read_pot_settings()
            self.message = f"node {self.current.node}: pot settings read"

    def _power(self, targets: Sequence[tuple[int, int]], on: bool) -> None:
        for index, watched in enumerate(self.boards):
            axes = [axis for board, axis in targets if board == index]
            if not axes:
                continue
            # Amplifiers already on belong to whoever switched them on: quitting
            # must not switch those off.
            reading = watched.reading
            was_on = reading.status.enables if reading else (False,) * watched.channels
            watched.board.set_power_control(watched.board.power_word(axes, on))
            watched.board.apply_all_outputs()
            for axis in axes:
                if not on:
                    self.enabled_here.discard((index, axis))
                elif not was_on[axis]:
                    self.enabled_here.add((index, axis))
        what = "on" if on else "off"
        if len(targets) == 1:
            self.message = f"node {self.current.node} ch {self.axis + 1}: amplifier {what}"
        else:
            self.message = f"all amplifiers {what}"

    def _present_dac(self) -> int:
        reading = self.current.reading
        return DAC_MIDPOINT if reading is None else reading.channels[self.axis].dac

    def _command(self, code: int) -> None:
        code = min(max(code, 0), DAC_MAX)
        watched = self.current
        watched.board.set_motor_voltage(self.axis, code)
        watched.board.apply_all_outputs()
        if code == DAC_MIDPOINT:
            self.commanded_here.discard(self.selected)
        else:
            self.commanded_here.add(self.selected)
        offset = code - DAC_MIDPOINT
        self.message = (
            f"node {watched.node} ch {self.axis + 1}: motor command {code:#06x} ({offset:+d})"
        )
        # Show the new command at once rather than one refresh later.
        watched.refresh()

    # --- the end -------------------------------------------------------------------
    def shutdown(self) -> tuple[list[str], bool]:
        """Stop the motors we commanded and switch off the amplifiers we enabled.

        Returns one line per board touched, for the terminal once curses has
        let go of it, and whether everything was made safe.
        """
        report = []
        safe = True
        for index, watched in enumerate(self.boards):
            stopped = sorted(a for b, a in self.commanded_here if b == index)
            switched = sorted(a for b, a in self.enabled_here if b == index)
            if not stopped and not switched:
                continue
            error = _make_safe(watched, stopped, switched)
            if error is not None:
                names = ",".join(str(axis + 1) for axis in sorted({*stopped, *switched}))
                report.append(f"node {watched.node}: channels {names} NOT made safe: {error}")
                safe = False
                continue
            done = []
            if stopped:
                done.append("motor command " + ",".join(str(a + 1) for a in stopped) + " stopped")
            if switched:
                done.append("amplifier " + ",".join(str(a + 1) for a in switched) + " off")
            report.append(f"node {watched.node}: " + "; ".join(done))
        self.enabled_here.clear()
        self.commanded_here.clear()
        return report, safe


def _make_safe(
    watched: WatchedBoard, stopped: Sequence[int], switched: Sequence[int]
) -> str | None:
    """Stop ``stopped`` and switch off ``switched``; the error if two attempts failed.

    Two attempts, because one transaction can fail just for a bus reset
    (another host joining) and this is the last chance to leave the motors safe.
    """
    problem = ""
    for _ in range(2):
        try:
            for axis in stopped:
                watched.board.set_motor_voltage(axis, DAC_MIDPOINT)
            if switched:
                watched.board.set_power_control(watched.board.power_word(switched, False))
            watched.board.apply_all_outputs()
        except BOARD_ERRORS as error:
            problem = str(error)
        else:
            return None
    return problem
