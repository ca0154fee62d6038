"""A data block travels padded with zero bytes to the next quadlet boundary (IEEE 1394-1995
block packets: data_length counts the bytes before the padding)."""

from __future__ import annotations

import pytest

from fw1394.crc import padded


@pytest.mark.parametrize("size", range(10))
def test_data_is_zero_padded_to_the_next_quadlet(size: int) -> None:
    data = bytes(range(1, size + 1))
    quadlets = -(-size // 4)
    assert padded(data) == data + bytes(4 * quadlets - size)
