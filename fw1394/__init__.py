"""fw1394: a wire-level IEEE 1394 (FireWire) protocol toolkit."""

from fw1394.errors import BusUnreachable, Error, PacketError, Timeout, TransactionError, UsageError

__version__ = "0.1.0"

__all__ = [
    "BusUnreachable",
    "Error",
    "PacketError",
    "Timeout",
    "TransactionError",
    "UsageError",
    "__version__",
]
