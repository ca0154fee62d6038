"""The PHY model's LREQ decoder: every request type, and malformed streams."""

from __future__ import annotations

import pytest

pytest.importorskip("cocotb", reason="cocotb is not installed (pip install 'fw1394[rtl]')")

from fw1394.rtl.phy import Phy, Request  # noqa: E402


def _decoded(*streams: str) -> tuple[list[Request], list[str]]:
    phy = Phy(None, physical_id=0, ack_gap=40, registers=None)
    for stream in streams:
        for bit in "0" + stream + "000":  # idle low before and after
            phy._lreq(int(bit))
    return list(phy.requests), phy.violations


@pytest.mark.parametrize(
    ("stream", "wanted"),
    [
        ("1" "000" "100" "0", Request(0, 0b100, 3)),  # ImmReq at S400 (an ack)
        ("1" "011" "010" "0", Request(3, 0b010, 3)),  # FairReq at S200
        ("1" "100" "0101" "0", Request(4, 5, 4)),  # RdReg of register 5
        ("1" "101" "0001" "01000000" "0", Request(5, 0x140, 12)),  # WrReg IBR
        ("1" "110" "1" "0", Request(6, 1, 1)),  # AccelCtl
    ],
)
def test_each_request_type_is_decoded(stream: str, wanted: Request) -> None:
    assert _decoded(stream) == ([wanted], [])


def test_back_to_back_requests() -> None:
    requests, violations = _decoded("1" "100" "0000" "0" "1" "000" "100" "0")
    assert requests == [Request(4, 0, 4), Request(0, 0b100, 3)] and violations == []


def test_malformed_streams_are_interface_violations() -> None:
    requests, violations = _decoded("1" "111" "0000")
    assert requests == [] and violations[0].startswith("lreq-reserved:")
    requests, violations = _decoded("1" "000" "100" "1")
    assert requests == [] and violations[0].startswith("lreq-stop:")
