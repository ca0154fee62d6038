"""The 1394 CRC against the catalogue, the worked examples and captured traffic."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fw1394.crc import CHECK_VALUE, crc16_1212, crc32, data_crc, header_crc, padded

VECTORS = Path(__file__).parents[1] / "vectors"
REFERENCE = json.loads((VECTORS / "crc32_reference_computed.json").read_text())
CAPTURED = json.loads((VECTORS / "jhu_eth1394_captured.json").read_text())


def quadlets(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", ""))


def test_catalogue_check_value() -> None:
    assert crc32(b"123456789") == CHECK_VALUE == int(REFERENCE["parameters"]["check_123456789"], 16)


def test_crc_of_nothing_is_zero() -> None:
    # The spec notes an empty data block's CRC would be 0.
    assert data_crc(b"") == 0


@pytest.mark.parametrize(
    "example", REFERENCE["worked_examples"], ids=lambda e: e["input_description"]
)
def test_worked_examples(example: dict[str, str]) -> None:
    raw = quadlets(example["input_quadlets_be_hex"])
    assert header_crc(raw) == int(example["crc32_1394"], 16)
    # The two classic mistakes give other values: the check is not vacuous.
    assert header_crc(raw) != int(example["wrong_zlib_crc32_reflected_over_same_bytes"], 16) or (
        raw == b"\xff\xff\xff\xff"
    )


@pytest.mark.parametrize("vector", CAPTURED["vectors"], ids=lambda v: v["description"])
def test_captured_datagrams(vector: dict[str, object]) -> None:
    words = quadlets(str(vector["packet_hex"]))
    tcode = vector["fields"]["tcode"]  # type: ignore[index]
    header_quadlets = 3 if tcode == 4 else 4
    assert header_crc(words[: 4 * header_quadlets]) == vector["header_crc"]
    if vector["data_crc"] is not None:
        data = words[4 * (header_quadlets + 1) : -4]
        assert data_crc(data) == vector["data_crc"]


def test_data_crc_pads_to_quadlet() -> None:
    assert padded(b"\x01") == b"\x01\x00\x00\x00"
    assert data_crc(b"\x01\x02") == crc32(b"\x01\x02\x00\x00")


def _crc16_by_nibbles(data: bytes) -> int:
    """IEEE 1212's configuration-ROM CRC as the standard states it, four bits at a time."""
    crc = 0
    for index in range(0, len(data), 4):
        quadlet = int.from_bytes(data[index : index + 4], "big")
        for shift in (28, 24, 20, 16, 12, 8, 4, 0):
            total = ((crc >> 12) ^ (quadlet >> shift)) & 0xF
            crc = ((crc << 4) ^ (total << 12) ^ (total << 5) ^ total) & 0xFFFF
    return crc


@pytest.mark.parametrize(
    "data",
    [
        bytes(4),
        bytes.fromhex("31333934 00ffa000 fa610e06 00000000"),  # a QLA bus-info block
        bytes(range(64)),
    ],
)
def test_crc16_1212_is_the_standards_nibble_algorithm(data: bytes) -> None:
    assert crc16_1212(data) == _crc16_by_nibbles(data)
