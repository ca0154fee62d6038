"""Which transaction codes ask and which answer, and the answer each request expects.

IEEE 1394-1995 §6.2.4.4 pairs every request tcode with the response tcode
that completes it; the transaction engine checks responses against it and
the capture analysis pairs trace records by it.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from fw1394.packets.enums import TCode

#: request tcode -> the tcode its response must carry.
RESPONSE_OF_REQUEST: Mapping[TCode, TCode] = MappingProxyType(
    {
        TCode.write_quadlet_request: TCode.write_response,
        TCode.write_block_request: TCode.write_response,
        TCode.read_quadlet_request: TCode.read_quadlet_response,
        TCode.read_block_request: TCode.read_block_response,
        TCode.lock_request: TCode.lock_response,
    }
)
#: Tcodes of packets that start a transaction.
REQUEST_TCODES: frozenset[TCode] = frozenset(RESPONSE_OF_REQUEST)
#: Tcodes of packets that complete one.
RESPONSE_TCODES: frozenset[TCode] = frozenset(RESPONSE_OF_REQUEST.values())
