"""Plain memory as a register map: one byte-addressed array, every offset bit decoded."""

from __future__ import annotations

from fw1394.boards.regmap import Group, Register, RegisterMap

#: The size the registry builds (64 KiB).
DEFAULT_SIZE = 0x1_0000


def memory_map(size: int = DEFAULT_SIZE) -> RegisterMap:
    """The map of a :class:`~fw1394.boards.memory.board.MemorySpace` of ``size`` bytes at 0."""
    memory = Register("MEMORY", 0, "rw", 0, "the bytes stored", "stores the bytes", count=size // 4)
    return RegisterMap(
        "memory",
        (Group("memory", (memory,)),),
        quadlet_index=False,
        probe="MEMORY",
        # Misaligned quadlets (one past the end is an array spot already).
        spots=(2, 6, size - 2),
    )


REGISTER_MAP = memory_map()
