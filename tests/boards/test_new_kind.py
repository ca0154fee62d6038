"""A board kind is one package plus one registry line: nothing else changes to use it.

The kind here lives only in this file and is registered at run time; the
fuzzer (in-process target, reference model, offsets, default policy, planted
defects) and the node process's board factory pick it up from the registry.
"""

from __future__ import annotations

import pytest

from fw1394.boards.registry import BOARDS, BoardKind, check_defects, known_defects
from fw1394.boards.regmap import Decoding, Group, Register, RegisterMap
from fw1394.engine.space import AddressError
from fw1394.fuzz.campaign import run
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.settings import Settings, default_policy
from fw1394.fuzz.targets import open_target

KIND = "scratch"
IDENTITY = 0x5C7A_0001
#: A register a write changes; the planted defect makes it forget the write.
SCRATCH_REGISTERS = 4

REGISTERS = RegisterMap(
    KIND,
    (
        Group(
            "board",
            (
                Register("IDENTITY", 0, "ro", IDENTITY, "0x5C7A0001", "ignored"),
                Register(
                    "SCRATCH", 1, "rw", 0, "last value written", "stored", count=SCRATCH_REGISTERS
                ),
            ),
        ),
    ),
    decodings={"firewire": Decoding(kept=0xFF)},
    probe="IDENTITY",
)


class ScratchBoard:
    """Five quadlets: an identity register and four scratch registers, 8 offset bits decoded."""

    def __init__(self, *, board_id: int = 0, defects: frozenset[str] = frozenset()) -> None:
        self.board_id = board_id
        self.defects = defects
        self.scratch = [0] * SCRATCH_REGISTERS

    def _index(self, offset: int) -> int:
        return REGISTERS.decode(offset)

    def read_quadlet(self, offset: int) -> int:
        index = self._index(offset)
        if index == 0:
            return IDENTITY
        if 1 <= index <= SCRATCH_REGISTERS:
            return self.scratch[index - 1]
        raise AddressError(f"nothing at {offset:#x}")

    def write_quadlet(self, offset: int, value: int) -> None:
        index = self._index(offset)
        if 1 <= index <= SCRATCH_REGISTERS and "forgets-writes" not in self.defects:
            self.scratch[index - 1] = value
        elif not 0 <= index <= SCRATCH_REGISTERS:
            raise AddressError(f"nothing at {offset:#x}")

    def read_block(self, offset: int, length: int) -> bytes:
        if length % 4:
            raise AddressError("whole quadlets only")
        start = self._index(offset)
        return b"".join(self.read_quadlet(start + n).to_bytes(4, "big") for n in range(length // 4))

    def write_block(self, offset: int, data: bytes) -> None:
        start = self._index(offset)
        for n in range(0, len(data) - 3, 4):
            self.write_quadlet(start + n // 4, int.from_bytes(data[n : n + 4], "big"))

    def set_time(self, ticks: int) -> None:
        pass


@pytest.fixture
def registered(monkeypatch: pytest.MonkeyPatch) -> BoardKind:
    # The one registry line a new kind needs.
    kind = BoardKind(
        KIND,
        "five quadlets for tests",
        ScratchBoard,
        policy="ieee1394",
        defects=frozenset({"forgets-writes"}),
        registers=REGISTERS,
    )
    monkeypatch.setitem(BOARDS, KIND, kind)
    return kind


def settings(*defects: str) -> Settings:
    return Settings(f"inproc:{KIND}", defects=defects, max_cases=400, seed=0, shrink_budget=0)


@pytest.mark.usefixtures("registered")
def test_the_fuzzer_aims_at_the_new_boards_registers() -> None:
    model = offset_model(KIND)
    assert model.probe == 0
    assert {0, 1, 2, 3, 4, 5} <= set(model.registers)  # 5: one past the array
    assert set(model.sweep) == {1, 2, 3, 4}
    assert model.quadlet_index


@pytest.mark.usefixtures("registered")
def test_the_fuzzer_runs_the_new_board_in_process_with_its_own_policy() -> None:
    assert default_policy(KIND) == "ieee1394"
    target = open_target(settings())
    assert isinstance(target.responder.space, ScratchBoard)  # type: ignore[attr-defined]
    report = run(settings())
    assert report.cases == 400
    assert report.checks["state"] > 0


@pytest.mark.usefixtures("registered")
def test_a_defect_the_new_board_plants_is_known_and_found() -> None:
    assert "forgets-writes" in known_defects(KIND)
    assert check_defects(KIND, ["forgets-writes"]) == {"forgets-writes"}
    report = run(settings("forgets-writes"))
    assert {finding.oracle for finding in report.findings} & {"state", "reply"}


def test_without_its_registry_line_the_kind_does_not_exist() -> None:
    with pytest.raises(ValueError, match="unknown board kind"):
        open_target(settings())


@pytest.mark.usefixtures("registered")
def test_the_node_process_builds_the_new_board() -> None:
    from fw1394.node.description import NodeDescription
    from fw1394.node.run import _board

    space = _board(NodeDescription(board=KIND, board_id=3, defects=frozenset({"forgets-writes"})))
    assert isinstance(space, ScratchBoard)
    assert space.board_id == 3 and space.defects == {"forgets-writes"}
