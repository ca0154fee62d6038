"""fw1394: a wire-level IEEE 1394 (FireWire) protocol toolkit."""

__version__ = "0.1.0"
