"""The link layer's address recognition, as a classic BPF socket filter.

Every member's socket receives every datagram of the bus group (the PHYs
repeat everything); like a 1394 link chip, the kernel then passes up only what
is addressed to this node: its own physical ID, broadcast (63) or every member
(0xFF). Frames of another bus and the member's own looped-back frames are
dropped too. Done in the kernel, this keeps 62 idle nodes from waking up for a
packet that is not theirs (``docs/virtual-bus.md`` has the measurements).
"""

from __future__ import annotations

import ctypes
import socket
import struct

from fw1394.packets.frame import FRAME_HEADER_SPANS
from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.transport.sansio.wire import EVERY_MEMBER, MAGIC, FrameKind

SO_ATTACH_FILTER = 26
#: For UDP sockets the filter sees the packet from the UDP header on.
UDP_HEADER = 8
_LD_W, _LD_H, _LD_B = 0x20, 0x28, 0x30  # BPF_LD | BPF_ABS | size
_LOAD_OF_SIZE = {4: _LD_W, 2: _LD_H, 1: _LD_B}
_JEQ = 0x15  # BPF_JMP | BPF_JEQ | BPF_K
_RET = 0x06  # BPF_RET | BPF_K
_ACCEPT = 0xFFFF_FFFF
_INSTRUCTION = struct.Struct("=HBBI")

Instruction = tuple[int, int, int, int]
#: Symbolic jump targets, resolved to relative offsets by :func:`_resolve`.
_NEXT, _DROP, _TAKE = "next", "drop", "accept"
Symbolic = tuple[int, str, str, int]


def load(field: str) -> tuple[int, int]:
    """The BPF load instruction and absolute offset that read a frame header field.

    Both come from the header's layout (:data:`fw1394.packets.frame.FRAME_HEADER`),
    so the filter reads what the transport writes.
    """
    offset, size = FRAME_HEADER_SPANS[field]
    return _LOAD_OF_SIZE[size], UDP_HEADER + offset


def _read(field: str) -> Symbolic:
    code, offset = load(field)
    return (code, _NEXT, _NEXT, offset)


def _program(
    tag: int, member_id: int | None, phy_id: int | None, drop_acks: bool
) -> list[Instruction]:
    steps: list[Symbolic] = [
        _read("magic"),
        (_JEQ, _NEXT, _DROP, MAGIC),
        _read("tag"),
        (_JEQ, _NEXT, _DROP, tag),
    ]
    if member_id is None:
        steps.append((_RET, _NEXT, _NEXT, _ACCEPT))
    else:
        steps += [
            _read("sender"),
            (_JEQ, _DROP, _NEXT, member_id),
        ]
        if drop_acks:
            # A responder has no use for the acks of its responses: not waking it
            # for them halves its work per transaction.
            steps += [
                _read("kind"),
                (_JEQ, _DROP, _NEXT, FrameKind.ack),
            ]
        steps.append(_read("destination"))
        wanted = [EVERY_MEMBER, BROADCAST_PHY] + ([] if phy_id is None else [phy_id])
        steps += [(_JEQ, _TAKE, _NEXT, value) for value in wanted]
    steps += [(_RET, _NEXT, _NEXT, 0), (_RET, _NEXT, _NEXT, _ACCEPT)]
    return _resolve(steps)


def _resolve(steps: list[Symbolic]) -> list[Instruction]:
    targets = {_DROP: len(steps) - 2, _TAKE: len(steps) - 1}

    def offset(index: int, target: str) -> int:
        return 0 if target == _NEXT else targets[target] - index - 1

    return [(code, offset(i, jt), offset(i, jf), k) for i, (code, jt, jf, k) in enumerate(steps)]


def attach(
    sock: socket.socket,
    tag: int,
    member_id: int | None,
    phy_id: int | None,
    drop_acks: bool = False,
) -> None:
    """Filter ``sock``: a bus member with ``phy_id``, or (``member_id`` None) a tap.

    A tap sees every frame of the bus; a member sees what its link would.
    """
    program = _program(tag, member_id, phy_id, drop_acks)
    code = b"".join(_INSTRUCTION.pack(*instruction) for instruction in program)
    buffer = ctypes.create_string_buffer(code)
    # struct sock_fprog { unsigned short len; struct sock_filter *filter; }; the kernel
    # copies the program during the call, so the buffer may go away afterwards.
    fprog = struct.pack("HL", len(program), ctypes.addressof(buffer))
    sock.setsockopt(socket.SOL_SOCKET, SO_ATTACH_FILTER, fprog)
