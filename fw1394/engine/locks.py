"""Lock transactions served by read-modify-write on an address space.

The engine runs one request at a time, so reading the old value and writing the
new one cannot be interleaved with another request: the operation is atomic as
the bus sees it. The arithmetic is that of IEEE 1212 / IEEE 1394 (the same as
the Linux raw1394 address-range emulation).
"""

from __future__ import annotations

from collections.abc import Callable

from fw1394.engine.space import AddressSpace, DataError, TypeError1394
from fw1394.packets import ExtendedTCode, LockRequest

#: Operand sizes the standard defines for the arithmetic lock functions.
_SIZES = (4, 8)

# Each function: (old, argument, data, bits) -> new value, big-endian integers.
_Operation = Callable[[int, int, int, int], int]


def _add(old: int, data: int, bits: int) -> int:
    return (old + data) & ((1 << bits) - 1)


def _little_add(old: int, data: int, bits: int) -> int:
    # The operands are little-endian numbers stored in big-endian quadlet order.
    size = bits // 8
    total = int.from_bytes(old.to_bytes(size, "big"), "little") + int.from_bytes(
        data.to_bytes(size, "big"), "little"
    )
    return int.from_bytes((total & ((1 << bits) - 1)).to_bytes(size, "little"), "big")


_OPERATIONS: dict[int, _Operation] = {
    ExtendedTCode.mask_swap: lambda old, arg, data, bits: data | (old & ~arg),
    ExtendedTCode.compare_swap: lambda old, arg, data, bits: data if old == arg else old,
    ExtendedTCode.fetch_add: lambda old, arg, data, bits: _add(old, data, bits),
    ExtendedTCode.little_add: lambda old, arg, data, bits: _little_add(old, data, bits),
    ExtendedTCode.bounded_add: lambda old, arg, data, bits: (
        _add(old, data, bits) if old != arg else old
    ),
    ExtendedTCode.wrap_add: lambda old, arg, data, bits: (
        _add(old, data, bits) if old != arg else data
    ),
}


def perform_lock(space: AddressSpace, request: LockRequest) -> bytes:
    """Carry out ``request`` on ``space``; the old value, as the lock response carries it.

    Raises :class:`DataError` for operand sizes the operation does not define and
    :class:`TypeError1394` for extended tcodes it does not implement (vendor-
    dependent ones included); errors of the space itself pass through.
    """
    operation = _OPERATIONS.get(request.extended_tcode)
    if operation is None:
        raise TypeError1394(f"extended tcode {request.extended_tcode:#x} is not implemented")
    argument, data = request.argument, request.lock_data
    size = len(data)
    if size not in _SIZES or (request.has_argument and len(argument) != size):
        raise DataError(f"lock data_length {request.data_length} does not fit the operation")
    offset = request.offset
    old_bytes = (
        space.read_quadlet(offset).to_bytes(4, "big")
        if size == 4
        else space.read_block(offset, size)
    )
    old = int.from_bytes(old_bytes, "big")
    new = operation(old, int.from_bytes(argument, "big"), int.from_bytes(data, "big"), 8 * size)
    if new != old:
        if size == 4:
            space.write_quadlet(offset, new)
        else:
            space.write_block(offset, new.to_bytes(size, "big"))
    return old_bytes
