"""Only members speak: sealing, verifying and the replay window (fw1394.transport.sansio.seal)."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets.frame import FRAME_TRAILER, FRAME_TRAILER_SIZE
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.seal import REPLAY_WINDOW, Sealer, Verifier
from fw1394.transport.sansio.wire import FrameHeader, FrameKind
from fw1394.transport.supervision.bus_key import (
    KEY_ENV,
    KEY_FILE_ENV,
    BusKeyError,
    key_for,
    new_key,
    read_key,
    write_key,
)

KEY = bytes(range(32))


def frame(sender: int = 7, generation: int = 3, payload: bytes = b"\x01\x02\x03\x04") -> bytes:
    return FrameHeader(FrameKind.async_packet, 0x1234, sender, generation, 1, 2).pack() + payload


def test_a_sealed_frame_opens_to_itself_and_the_trailer_is_the_layout() -> None:
    plain = frame()
    sealed = Sealer(KEY).seal(plain)
    trailer = FRAME_TRAILER.parse(sealed[len(plain) :])
    assert trailer.counter == 1 and len(sealed) == len(plain) + FRAME_TRAILER_SIZE
    assert Verifier(KEY).open(sealed) == plain


@given(st.data())
def test_any_changed_byte_makes_a_forgery(data: st.DataObject) -> None:
    sealed = bytearray(Sealer(KEY).seal(frame()))
    position = data.draw(st.integers(0, len(sealed) - 1))
    sealed[position] ^= data.draw(st.integers(1, 255))
    verifier = Verifier(KEY)
    assert verifier.open(bytes(sealed)) is None
    assert (verifier.dropped.forged, verifier.dropped.replayed) == (1, 0)


def test_other_keys_short_frames_and_plain_frames_are_forgeries() -> None:
    verifier = Verifier(KEY)
    assert verifier.open(Sealer(bytes(32)).seal(frame())) is None
    assert verifier.open(frame()) is None
    assert verifier.open(b"FW") is None
    assert verifier.dropped.forged == 3


def test_replays_are_dropped_even_across_generations() -> None:
    sealer, verifier = Sealer(KEY), Verifier(KEY)
    old = sealer.seal(frame(generation=3))
    assert verifier.open(old) is not None
    newer = [sealer.seal(frame(generation=4)) for _ in range(3)]
    assert all(verifier.open(f) is not None for f in newer)
    assert verifier.open(old) is None and verifier.open(newer[1]) is None
    assert verifier.dropped.replayed == 2 and verifier.dropped.forged == 0


@given(st.permutations(range(REPLAY_WINDOW)), st.integers(0, REPLAY_WINDOW - 1))
def test_reordering_within_the_window_passes_once(order: list[int], again: int) -> None:
    sealer, verifier = Sealer(KEY), Verifier(KEY)
    frames = [sealer.seal(frame()) for _ in range(REPLAY_WINDOW)]
    assert all(verifier.open(frames[i]) is not None for i in order)
    assert verifier.open(frames[again]) is None
    # Far behind the newest: dropped even if never seen.
    late = sealer.seal(frame())
    for _ in range(REPLAY_WINDOW):
        verifier.open(sealer.seal(frame()))
    assert verifier.open(late) is None


def test_senders_have_windows_of_their_own() -> None:
    one, two, verifier = Sealer(KEY), Sealer(KEY), Verifier(KEY)
    assert verifier.open(one.seal(frame(sender=1))) is not None
    assert verifier.open(two.seal(frame(sender=2))) is not None  # counter 1 again
    assert verifier.dropped.total == 0


def test_key_file_is_private_and_found(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    for name in (KEY_ENV, KEY_FILE_ENV):
        monkeypatch.delenv(name, raising=False)
    path = tmp_path / "key"
    key = new_key()
    write_key(path, key)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert read_key(path) == key
    monkeypatch.setenv(KEY_FILE_ENV, str(path))
    assert key_for(BusConfig("anything")) == key
    assert key_for(BusConfig("anything", key=b"")) is None  # explicitly insecure
    monkeypatch.setenv(KEY_ENV, "00" * 16)
    assert key_for(BusConfig("anything")) == bytes(16)
    os.chmod(path, 0o644)
    monkeypatch.delenv(KEY_ENV)
    with pytest.raises(BusKeyError, match="readable by them only"):
        key_for(BusConfig("anything"))
    monkeypatch.setenv(KEY_ENV, "not hex")
    with pytest.raises(BusKeyError, match="hex"):
        key_for(BusConfig("anything"))
