"""A data oracle that needs no model: registers that read back what was written.

Without ``--model`` nothing says what a register should hold, but a node's
own answers do: a register that reads back the value a write put there is
memory-like (once two different values came back as written), and from then
on it must keep holding what was last written to
it until a write touches it again. The oracle learns such registers from the
campaign's writes and their read-backs, and at every sweep reads each one
(``learned:changed`` if it no longer holds its value although no write touched
it: a write elsewhere changed it), then writes it a fresh marker and reads that
back (``learned:not-read-back`` if a register that kept writes before does not
keep this one, in bits it kept both as 0 and 1 before: a register that
implements only some bits is not reported for the others).

The markers make a finding local: the sweep before the violation taught the
register its value, so the stream from there on reproduces it on a fresh
node. Registers are keyed by the register an offset reaches on a board that
decodes 16 bits (:func:`fw1394.fuzz.offsets.canonical`); a write touches the
registers its data covers, by quadlet index or by byte as the target
addresses them.
"""

from __future__ import annotations

from fw1394.fuzz.judge import Violation
from fw1394.fuzz.offsets import canonical
from fw1394.packets import (
    AsyncPacket,
    BlockWriteRequest,
    LockRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
)
from fw1394.packets.fast import decode_sound

#: Registers learned at most (the sweep reads, writes and reads back each one).
LIMIT = 64
_DECODED = 1 << 16
_GOLDEN = 0x9E3779B1


class LearnedRegisters:
    """What the node's answers taught about its registers (``quadlet_index``: the
    node addresses registers by index, else by byte)."""

    def __init__(self, quadlet_index: bool, limit: int = LIMIT) -> None:
        self.quadlet_index = quadlet_index
        self.limit = limit
        #: register -> value written to it, waiting for its read-back
        self._pending: dict[int, int] = {}
        #: memory-like registers -> the value they hold (None: a write touched it since)
        self._known: dict[int, int | None] = {}
        #: register -> (the first value it read back, bits it kept as 1, bits kept as 0)
        self._kept: dict[int, tuple[int, int, int]] = {}
        self._markers = 0

    def reset(self) -> None:
        """A fresh node: nothing it answered before holds any more."""
        self._pending.clear()
        self._known.clear()
        self._kept.clear()

    @property
    def registers(self) -> tuple[int, ...]:
        """What a sweep reads and teaches: the memory-like registers, and those that read
        back one write (a marker of another value tells whether they are)."""
        candidates = (r for r in self._kept if r not in self._known)
        return (*self._known, *candidates)[: self.limit]

    # -- what was sent -------------------------------------------------------------------
    def wrote(self, packet: AsyncPacket, accepted: bool) -> None:
        """A write or lock of the campaign (to any node): what it may have touched is
        unknown from now on; an accepted quadlet write waits for its read-back."""
        offset = getattr(packet, "offset", None)
        if offset is None:
            return
        start = canonical(offset)
        span = self._span(packet)
        # The 16 bits decoded wrap: a block written at 0xFFFC goes on at 0.
        if not self.quadlet_index:
            start, span = start - 3, span + 3  # a misaligned byte write reaches back
        for register in self._known:
            if (register - start) % _DECODED < span:
                self._known[register] = None
        self._pending.pop(start, None)
        if accepted and isinstance(packet, QuadletWriteRequest):
            self._pending[start] = packet.quadlet_data

    def marker(self, register: int) -> int:
        """A value to write to ``register`` now, never the one before (bit 0 alternates)."""
        self._markers += 1
        value = (self._markers * _GOLDEN ^ register << 8) & 0xFFFFFFFE | self._markers & 1
        self._pending[register] = value
        return value

    def taught(self, register: int, value: int) -> None:
        """The trial wrote ``value`` to ``register`` (a marker, as replayed)."""
        self._pending[canonical(register)] = value

    # -- what came back ------------------------------------------------------------------
    def read_back(self, offset: int, response: object) -> Violation | None:
        """The read-back of a write to ``offset``."""
        register = canonical(offset)
        want = self._pending.pop(register, None)
        value = quadlet_of(response)
        if want is None or value is None:
            return None
        if value == want:
            self._learn(register, value)
            return None
        if register not in self._known:
            self._kept.pop(register, None)  # not memory-like: read-only, or a mind of its own
            return None
        self._known[register] = value
        _, ones, zeros = self._kept[register]
        if not (want ^ value) & ones & zeros:
            return None  # bits it never kept both ways: unimplemented ones, say
        return Violation(
            "state",
            "learned:not-read-back",
            f"register {register:#x}: {want:#010x} (it read back what was written before)",
            f"register {register:#x}: {value:#010x}",
        )

    def _learn(self, register: int, value: int) -> None:
        """``register`` read back ``value`` as written: memory-like once two different
        values came back."""
        first, ones, zeros = self._kept.get(register, (value, 0, 0))
        self._kept[register] = (first, ones | value, zeros | ~value & 0xFFFFFFFF)
        if register in self._known:
            self._known[register] = value
        elif first != value:
            if len(self._known) >= self.limit:
                del self._known[next(iter(self._known))]  # the one learned longest ago
            self._known[register] = value

    def swept(self, offset: int, response: object, writes: str) -> Violation | None:
        """A sweep read of ``offset``; ``writes`` names the writes since it was taught."""
        register = canonical(offset)
        value = quadlet_of(response)
        if register not in self._known or value is None:
            return None
        want, self._known[register] = self._known[register], value
        if want is None or value == want:
            return None
        return Violation(
            "state",
            "learned:changed",
            f"register {register:#x}: {want:#010x} (written, and read back)",
            f"register {register:#x}: {value:#010x}{writes}",
        )

    def _span(self, packet: AsyncPacket) -> int:
        """Registers (by index) or bytes a write covers."""
        if isinstance(packet, BlockWriteRequest | LockRequest):
            size = max(len(packet.data), 4)
        else:
            size = 4
        return (size + 3) // 4 if self.quadlet_index else size


def quadlet_of(response: object) -> int | None:
    """The data of a quadlet read response (as bytes or decoded), else None."""
    if isinstance(response, bytes):
        response = decode_sound(response)
    if isinstance(response, QuadletReadResponse) and response.rcode == 0:
        return response.quadlet_data
    return None
