"""Named values of the 1394 packet fields, in the Linux kernel's vocabulary."""

from __future__ import annotations

from enum import IntEnum


class TCode(IntEnum):
    """Transaction codes (header quadlet 0, bits 7..4)."""

    write_quadlet_request = 0x0
    write_block_request = 0x1
    write_response = 0x2
    read_quadlet_request = 0x4
    read_block_request = 0x5
    read_quadlet_response = 0x6
    read_block_response = 0x7
    cycle_start = 0x8
    lock_request = 0x9
    stream_data = 0xA
    lock_response = 0xB


class Retry(IntEnum):
    """Retry codes (header quadlet 0, bits 9..8)."""

    retry_1 = 0
    retry_X = 1
    retry_A = 2
    retry_B = 3


class RCode(IntEnum):
    """Response codes (response header quadlet 1, bits 15..12)."""

    resp_complete = 0x0
    resp_conflict_error = 0x4
    resp_data_error = 0x5
    resp_type_error = 0x6
    resp_address_error = 0x7


class ExtendedTCode(IntEnum):
    """Extended transaction codes of lock requests and responses."""

    mask_swap = 0x1
    compare_swap = 0x2
    fetch_add = 0x3
    little_add = 0x4
    bounded_add = 0x5
    wrap_add = 0x6
    vendor_dependent = 0x7


class AckCode(IntEnum):
    """Acknowledge codes (the 4-bit code of an ack packet)."""

    ack_complete = 0x1
    ack_pending = 0x2
    ack_busy_X = 0x4
    ack_busy_A = 0x5
    ack_busy_B = 0x6
    ack_tardy = 0xB
    ack_conflict_error = 0xC
    ack_data_error = 0xD
    ack_type_error = 0xE
    ack_address_error = 0xF


class Speed(IntEnum):
    """Speed codes of self-ID packets and capture records."""

    S100 = 0
    S200 = 1
    S400 = 2
    S800 = 3


class PortStatus(IntEnum):
    """Port status of self-ID packets."""

    none = 0
    not_connected = 1
    parent = 2
    child = 3


class PowerClass(IntEnum):
    """Power class of self-ID packet #0."""

    no_power = 0
    provides_15W = 1
    provides_30W = 2
    provides_45W = 3
    uses_1W = 4
    uses_3W = 5
    uses_6W = 6
    uses_10W = 7


class PhyPacketType(IntEnum):
    """The type field of 1394a extended PHY packets (identifier 0, R=0, T=0)."""

    ping = 0x0
    remote_access_base = 0x1
    remote_reply_base = 0x3
    remote_access_paged = 0x5
    remote_reply_paged = 0x7
    remote_command = 0x8
    remote_confirmation = 0xA
    resume = 0xF


def name_of(enum: type[IntEnum], value: int) -> str:
    """The enum member's name, or ``reserved_0x..`` for values it does not define."""
    try:
        return enum(value).name
    except ValueError:
        return f"reserved_{value:#x}"
