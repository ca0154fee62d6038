"""How one node answers requests: a policy per node, chosen by configuration."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Final, Literal, get_args

ReadMode = Literal["concatenated", "split"]
WriteMode = Literal["unified", "split"]
BadCrcMode = Literal["drop", "ack_data_error"]
UnsupportedMode = Literal["silent", "ack_type_error"]
AddressErrorMode = Literal["ack", "rcode"]


@dataclass(frozen=True, slots=True)
class ResponderPolicy:
    """The choices in which 1394 nodes differ when they answer a request.

    The defaults are those of an ordinary IEEE 1394 node; :data:`THESIS_FPGA`,
    :data:`IEEE1394_NODE` and :data:`JHU_FIRMWARE` are the presets.
    """

    #: Reads (and locks): response concatenated to ack_pending, or split.
    read_mode: ReadMode = "split"
    #: Writes: unified (ack_complete ends them) or split (ack_pending + write response).
    write_mode: WriteMode = "split"
    #: A packet with a bad CRC or length: dropped silently, or acked ack_data_error.
    bad_crc: BadCrcMode = "ack_data_error"
    #: Perform a damaged write anyway (the JHU firmware commits before the CRC arrives).
    write_despite_bad_crc: bool = False
    #: A tcode the node does not implement: no ack at all, or ack_type_error.
    unsupported_tcode: UnsupportedMode = "ack_type_error"
    #: An AddressError from the space: ack_address_error, or resp_address_error in
    #: the response (a unified write has no response, so it always uses the ack).
    address_error: AddressErrorMode = "rcode"
    #: A header that fails its CRC cannot be trusted, not even its destination, so
    #: the standard ignores it; the JHU link matches the destination while the
    #: packet arrives and acks ack_data_error at its end.
    drop_bad_header_crc: bool = True
    #: The JHU link never compares a block write's header CRC (only the data CRC).
    check_block_write_header_crc: bool = True
    #: Match only the 6-bit physical ID (thesis and JHU boards), not the bus ID.
    ignore_bus_id: bool = False
    #: Serve lock requests (by read-modify-write on the space); otherwise lock is an
    #: unsupported tcode.
    locks: bool = True

    def __post_init__(self) -> None:
        for name, allowed in (
            ("read_mode", ReadMode),
            ("write_mode", WriteMode),
            ("bad_crc", BadCrcMode),
            ("unsupported_tcode", UnsupportedMode),
            ("address_error", AddressErrorMode),
        ):
            value = getattr(self, name)
            if value not in get_args(allowed):
                raise ValueError(f"{name}={value!r}: expected one of {get_args(allowed)}")


#: The thesis FPGA (§6.1, §6.4): concatenated reads, unified writes, damaged
#: packets and unsupported tcodes silently ignored, quadlet/block reads and
#: writes only, node matched by its physical ID.
THESIS_FPGA: Final = ResponderPolicy(
    read_mode="concatenated",
    write_mode="unified",
    bad_crc="drop",
    unsupported_tcode="silent",
    address_error="ack",
    ignore_bus_id=True,
    locks=False,
)

#: An ordinary node as IEEE 1394 describes it: split transactions, ack_data_error,
#: ack_type_error, errors in the rcode, locks served.
IEEE1394_NODE: Final = ResponderPolicy()

#: The JHU FPGA1394 firmware's FireWire link (jhu-eth1394.md §3.1, §3.3): like the
#: thesis, but a damaged packet addressed to it is acked ack_data_error and a
#: damaged write is performed all the same.
JHU_FIRMWARE: Final = ResponderPolicy(
    read_mode="concatenated",
    write_mode="unified",
    bad_crc="ack_data_error",
    write_despite_bad_crc=True,
    unsupported_tcode="silent",
    address_error="ack",
    drop_bad_header_crc=False,
    check_block_write_header_crc=False,
    ignore_bus_id=True,
    locks=False,
)

#: The thesis's fast replies with locks served: reads in the ack's bus tenure and
#: writes acked complete, the fewest subactions (plain memory nodes use it).
QUICK_NODE: Final = replace(IEEE1394_NODE, read_mode="concatenated", write_mode="unified")

#: Every policy by the name the CLI, the board registry and the fuzzer use.
POLICIES: Final[dict[str, ResponderPolicy]] = {
    "thesis": THESIS_FPGA,
    "ieee1394": IEEE1394_NODE,
    "jhu": JHU_FIRMWARE,
    "quick": QUICK_NODE,
}
