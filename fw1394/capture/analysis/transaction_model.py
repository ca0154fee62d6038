"""What a transaction is: kinds, flags, protocol constants and column names."""

from __future__ import annotations

from enum import IntEnum, IntFlag

import numpy as np

from fw1394.packets import AckCode, ExtendedTCode, TCode
from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.packets.tcodes import RESPONSE_OF_REQUEST

I64 = np.int64

#: The response tcode each request expects.
EXPECTED_RESPONSE = RESPONSE_OF_REQUEST
REQUESTS = np.array(sorted(EXPECTED_RESPONSE), I64)
RESPONSES = np.array(sorted(set(EXPECTED_RESPONSE.values())), I64)
WRITES = np.array([TCode.write_quadlet_request, TCode.write_block_request], I64)
#: Acks after which the requester tries again (1394a: ack_tardy means "suspended, retry").
RETRY_ACKS = np.array(
    [AckCode.ack_busy_X, AckCode.ack_busy_A, AckCode.ack_busy_B, AckCode.ack_tardy], I64
)
ERROR_ACKS = np.array(
    [
        AckCode.ack_conflict_error,
        AckCode.ack_data_error,
        AckCode.ack_type_error,
        AckCode.ack_address_error,
    ],
    I64,
)
#: Ack code 0 in a trace: the sender saw no ack at all (nosy "no ack", OHCI evt_missing_ack).
NO_ACK = 0
#: Lock operations whose request carries an argument and data, and whose response half.
HALVED_LOCKS = [
    ExtendedTCode.mask_swap,
    ExtendedTCode.compare_swap,
    ExtendedTCode.bounded_add,
    ExtendedTCode.wrap_add,
]
#: The physical ID of broadcast, also the mask of a node ID's physical ID bits.
BROADCAST_NODE = BROADCAST_PHY


def code_table(codes: object) -> np.ndarray:
    """Membership table for 4-bit codes: ``table[values]`` works for values -1..15."""
    table = np.zeros(17, bool)  # index 16 (and so -1) stands for "no code"
    table[np.asarray(codes, I64)] = True
    return table


IS_REQUEST = code_table(REQUESTS)
IS_RESPONSE = code_table(RESPONSES)
IS_WRITE = code_table(WRITES)
IS_RETRY_ACK = code_table(RETRY_ACKS)
IS_ERROR_ACK = code_table(ERROR_ACKS)
IS_CLOSING_ACK = code_table([*ERROR_ACKS.tolist(), AckCode.ack_complete])
#: EXPECTED_RESPONSE as a lookup array indexed by request tcode (-1: not a request).
EXPECTED = np.full(16, -1, I64)
for _request, _response in EXPECTED_RESPONSE.items():
    EXPECTED[_request] = _response


class Kind(IntEnum):
    """How a transaction went."""

    unified = 0  # request acked ack_complete, no response needed
    split = 1  # ack_pending, response in a later subaction
    concatenated = 2  # ack_pending, response right after the ack
    answered = 3  # response seen, but the ack is unknown (UDP tunnels, logs without acks)
    broadcast = 4  # broadcast write: no ack, no response
    posted = 5  # write with neither ack nor response seen (UDP writes are never answered)
    failed = 6  # error ack, missing ack, or still busy when it ended
    unanswered = 7  # accepted (or unknown) but no response arrived
    unsolicited = 8  # response without a request


class Flag(IntFlag):
    """Notes and errors on a transaction."""

    no_response = 0x001
    unsolicited = 0x002
    tcode_mismatch = 0x004
    length_mismatch = 0x008
    crc_error = 0x010
    malformed = 0x020
    ack_error = 0x040
    busy = 0x080
    rcode_error = 0x100
    bus_reset = 0x200
    capture_end = 0x400
    label_reused = 0x800
    no_ack = 0x1000
    timeout = 0x2000


ERROR_FLAGS = (
    Flag.no_response
    | Flag.unsolicited
    | Flag.tcode_mismatch
    | Flag.length_mismatch
    | Flag.crc_error
    | Flag.malformed
    | Flag.ack_error
    | Flag.rcode_error
    | Flag.no_ack
)

#: Columns of the request side of a transaction (its last attempt, first-attempt times).
REQUEST_COLUMNS = (
    "first_ordinal",
    "first_frame",
    "first_ts",
    "ordinal",
    "pkt_ordinal",
    "frame",
    "ts",
    "time_known",
    "epoch",
    "generation",
    "requester",
    "responder",
    "tlabel",
    "tcode",
    "ack",
    "offset",
    "data_length",
    "quadlet_data",
    "extended_tcode",
    "attempts",
    "busy",
    "problems",
    "bidx",
)
RESPONSE_COLUMNS = (
    "resp_ordinal",
    "resp_pkt_ordinal",
    "resp_frame",
    "resp_ts",
    "resp_time_known",
    "resp_tcode",
    "resp_ack",
    "rcode",
    "resp_data_length",
    "resp_quadlet",
    "resp_problems",
    "resp_bidx",
)
COLUMNS = (*REQUEST_COLUMNS, *RESPONSE_COLUMNS, "kind", "flags", "latency_ns")
#: A response event also carries the keys it is matched by.
MATCH_KEYS = ("epoch", "generation", "requester", "responder", "tlabel")
#: How long an open request waits for its response before it counts as unanswered.
DEFAULT_EXPIRY_NS = 1_000_000_000


def flag_names(bits: int) -> list[str]:
    """Names of the :class:`Flag` bits set in ``bits``."""
    return [flag.name for flag in Flag if bits & flag and flag.name]
