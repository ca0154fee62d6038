"""The one error type the codec raises: :class:`fw1394.errors.PacketError`, named here too."""

from __future__ import annotations

from fw1394.errors import PacketError

__all__ = ["PacketError"]
