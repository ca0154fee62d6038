"""A board's register map as data: what sits where, and how an offset reaches it.

One :class:`RegisterMap` per board kind (``fw1394/boards/<kind>/regmap.py``)
is the single description the emulator decodes through, the host library
takes its offsets from, the fuzzer derives its target offsets from and the
register tables in ``docs/boards/`` are checked against.

Registers come in :class:`Group` s: a group is a list of :class:`Register` s
that may repeat (the motor channels of a board: copy ``c`` at
``base + c * stride``). How a 48-bit offset becomes a register address is a
:class:`Decoding`, one per path into the board (``"firewire"``, and
``"ethernet"`` where a board has a second way in), so a path that passes on
fewer offset bits, or a register space that ignores some bits, is one line
of data.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field, replace
from typing import Literal

OFFSET_MASK = (1 << 48) - 1
#: The primary path: requests that arrive as 1394 packets.
FIREWIRE = "firewire"
ETHERNET = "ethernet"

Access = Literal["ro", "rw", "wo"]
#: What the documentation prints in an empty Read or Write cell (an en dash).
NOTHING = "\u2013"


@dataclass(frozen=True)
class Register:
    """One register (or, with ``count`` > 1, an array of them) inside a group."""

    #: The name code uses (``map.offset("DAC", 2)``).
    name: str
    #: Address inside one copy of its group (a quadlet index on quadlet-index boards).
    index: int
    access: Access = "rw"
    #: Power-up value a quadlet read returns; None when it depends on the
    #: board's construction, its clock or another register.
    reset: int | None = None
    #: What a read returns and what a write does (the documentation's columns).
    read: str = ""
    write: str = ""
    #: The name the documentation prints, when it differs from ``name``.
    label: str = ""
    #: Bits that hold data (the rest read 0).
    bits: int = 32
    #: Registers in the array; consecutive addresses (4 bytes apart on byte-addressed maps).
    count: int = 1

    @property
    def title(self) -> str:
        return self.label or self.name


@dataclass(frozen=True)
class Group:
    """Registers that belong together; ``copies`` repeat them ``stride`` apart."""

    name: str
    registers: tuple[Register, ...]
    base: int = 0
    copies: range = range(1)
    stride: int = 0
    #: Whether addresses count quadlets; None: as the map says.
    quadlet_index: bool | None = None

    def address(self, register: Register, copy: int = 0) -> int:
        if copy not in self.copies:
            raise KeyError(f"{self.name} has no copy {copy} (copies {self.copies})")
        return self.base + copy * self.stride + register.index


@dataclass(frozen=True)
class IgnoredBits:
    """Offset bits a decoder ignores, where the offset matches ``when``."""

    mask: int
    when_mask: int = 0
    when_value: int = 0

    def applies(self, address: int) -> bool:
        return address & self.when_mask == self.when_value


@dataclass(frozen=True)
class Window:
    """A range of 48-bit offsets decoded as themselves (no aliasing), e.g. the CSRs."""

    base: int
    size: int

    def __contains__(self, offset: object) -> bool:
        return isinstance(offset, int) and self.base <= offset < self.base + self.size


@dataclass(frozen=True)
class Decoding:
    """How one path into the board turns a 48-bit offset into a register address."""

    #: Offset bits that reach the register decoder; the others alias.
    kept: int = OFFSET_MASK
    #: Bits inside ``kept`` a register space ignores (they alias too).
    ignored: tuple[IgnoredBits, ...] = ()
    #: Ranges decoded as whole offsets, before ``kept`` applies.
    windows: tuple[Window, ...] = ()

    def address(self, offset: int) -> int:
        """The register address ``offset`` reaches."""
        if not 0 <= offset <= OFFSET_MASK:
            raise ValueError(f"offset {offset:#x} is not a 48-bit 1394 offset")
        for window in self.windows:
            if offset in window:
                return offset
        address = offset & self.kept
        for rule in self.ignored:
            if rule.applies(address):
                address &= ~rule.mask
        return address

    def aliases(self, address: int, high: int) -> int:
        """An offset that decodes to ``address``, with ``high`` in the bits not kept.

        It differs from ``address`` unless the decoder keeps every offset bit.
        """
        spare = OFFSET_MASK & ~self.kept
        alias = address | (_spread(high, spare) if spare else 0)
        return alias & OFFSET_MASK


def _spread(value: int, mask: int) -> int:
    """``value``'s low bits placed into the set bits of ``mask`` (at least one set)."""
    out, bit = 0, 0
    for position in range(48):
        if mask >> position & 1:
            if value >> bit & 1:
                out |= 1 << position
            bit += 1
    return out or (mask & -mask)


@dataclass(frozen=True)
class Placed:
    """A register at its address: one copy of one register of one group."""

    group: Group
    register: Register
    copy: int
    address: int


@dataclass(frozen=True)
class RegisterMap:
    """Everything a board decodes, and how."""

    board: str
    groups: tuple[Group, ...]
    #: Path name -> decoding; every map has :data:`FIREWIRE`.
    decodings: Mapping[str, Decoding] = field(default_factory=lambda: {FIREWIRE: Decoding()})
    #: Addresses count quadlets (offset 4 is register 4) rather than bytes.
    quadlet_index: bool = True
    #: The register whose quadlet read always answers (liveness checks).
    probe: str = ""
    #: Addresses that hold nothing but are worth hitting (unmapped neighbours, decoder edges).
    spots: tuple[int, ...] = ()

    def group(self, name: str) -> Group:
        for group in self.groups:
            if group.name == name:
                return group
        raise KeyError(f"{self.board} has no register group {name!r}")

    def with_copies(self, group: str, copies: range) -> RegisterMap:
        """The same map with group ``group`` repeated ``copies`` times (fewer channels)."""
        groups = tuple(replace(g, copies=copies) if g.name == group else g for g in self.groups)
        self.group(group)
        return replace(self, groups=groups)

    def placed(self) -> Iterator[Placed]:
        """Every register copy at its address, group by group."""
        for group in self.groups:
            for copy in group.copies:
                for register in group.registers:
                    yield Placed(group, register, copy, group.address(register, copy))

    def register(self, name: str) -> tuple[Group, Register]:
        for group in self.groups:
            for register in group.registers:
                if register.name == name:
                    return group, register
        raise KeyError(f"{self.board} has no register {name!r}")

    def offset(self, name: str, copy: int | None = None) -> int:
        """The offset a host sends for register ``name`` (of channel/copy ``copy``)."""
        group, register = self.register(name)
        return group.address(register, group.copies[0] if copy is None else copy)

    def decode(self, offset: int, path: str = FIREWIRE) -> int:
        """The register address ``offset`` reaches over ``path``."""
        return self.decodings[path].address(offset)

    def at(self, address: int) -> Placed | None:
        """The register at ``address`` (an element of an array counts), or None."""
        for placed in self.placed():
            size = placed.register.count * self.step(placed.group)
            if placed.address <= address < placed.address + size:
                return placed
        return None

    def step(self, group: Group) -> int:
        """Address distance between consecutive quadlets of ``group``."""
        by_quadlet = self.quadlet_index if group.quadlet_index is None else group.quadlet_index
        return 1 if by_quadlet else 4


def markdown_table(group: Group, index_header: str = "Idx", index_prefix: str = "") -> str:
    """``group``'s registers as the documentation prints them (addresses within one copy)."""
    lines = [f"| {index_header} | Name | Access | Read | Write |", "|---|---|---|---|---|"]
    for register in group.registers:
        index = f"{index_prefix}{register.index:x}" if index_prefix else f"{register.index:#x}"
        lines.append(
            f"| {index} | {register.title} | {register.access} "
            f"| {register.read or NOTHING} | {register.write or NOTHING} |"
        )
    return "\n".join(lines)
