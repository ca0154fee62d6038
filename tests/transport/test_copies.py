"""Copies of answers never complete another transaction, at any depth.

A memory node that sends a fifth of its frames twice (and delays a tenth)
answers reads of 256 distinct words; the host keeps more transactions
outstanding than there are labels, so each label is handed out again the
moment its transaction ends, right before the copy of its answer arrives.
Every read must bring its own word.
"""

from __future__ import annotations

from collections.abc import Iterator

import pytest
from adapter_support import AdapterBus, adapter_bus
from hypothesis import example, given
from hypothesis import strategies as st

from fw1394.engine import ReadCompleted, TransactionFailed
from fw1394.engine.faults import FaultConfig
from fw1394.host.adapter_port import AdapterPort
from fw1394.host.bus_port import BusPort
from fw1394.transport.copies import WINDOW, RecentFrames
from fw1394.transport.host_adapter.protocol import Op, Status
from fw1394.transport.sansio.membership import Timing

WORDS = 256
READS = 3000
DEPTH = 100  # more than the 64 labels: the requester queues the rest


def word(k: int) -> int:
    return 0xC0DE_0000 | k


@given(
    st.lists(
        st.tuples(st.integers(1, 3), st.integers(0, 3 * WINDOW)),
        max_size=200,
    )
)
def test_a_frame_is_new_exactly_once(frames: list[tuple[int, int]]) -> None:
    check_once(frames)


#: Moves of a sender's sequence numbers: small ones, a third of the window, and
#: about a window forward or back (to where the window's far end just was).
STEPS = st.one_of(
    st.integers(-3, 3),
    st.integers(-1500, 1500),
    st.integers(WINDOW - 3, WINDOW + 3),
    st.integers(-WINDOW - 3, -WINDOW + 3),
)


@given(st.lists(st.tuples(st.integers(1, 2), STEPS), max_size=300))
# A jump of more than a window, and back to a number whose mark's byte was used a lap before:
@example([(1, 10), (1, WINDOW + 3), (1, -3)])
# The same with jumps inside the window, the last one short of the ring's end and across it:
@example([(1, 100), (1, 1900), (1, 2150), (1, 150), (1, -104)])
@example([(1, 4000), (1, 1000), (1, 3200), (1, -104)])
def test_a_frame_is_new_exactly_once_as_the_window_slides(steps: list[tuple[int, int]]) -> None:
    """Sequence numbers that climb and fall back by every size of step: the window
    laps several times, over the marks of earlier laps."""
    at = {1: 0, 2: 0}
    frames = []
    for sender, step in steps:
        at[sender] = max(0, at[sender] + step)
        frames.append((sender, at[sender]))
    check_once(frames)


@given(
    st.lists(st.integers(0, 3 * WINDOW), max_size=200),
    st.integers(1, 3 * WINDOW).map(lambda before: 2**32 - before),
)
def test_sequence_numbers_wrap(offsets: list[int], base: int) -> None:
    """The same frames with every sequence number moved by ``base`` (mod 2**32), so
    that the numbers wrap past 2**32 - 1 to 0 among them."""
    recent = RecentFrames()
    model = RecentFrames()
    for offset in offsets:
        assert recent.again(7, (base + offset) & 0xFFFFFFFF) == model.again(7, offset)


def check_once(frames: list[tuple[int, int]]) -> None:
    recent = RecentFrames()
    taken: set[tuple[int, int]] = set()
    highest: dict[int, int] = {}
    for sender, sequence in frames:
        too_old = sequence <= highest.get(sender, -1) - WINDOW
        again = recent.again(sender, sequence)
        assert again == ((sender, sequence) in taken or too_old), (sender, sequence)
        if not again:
            taken.add((sender, sequence))
            highest[sender] = max(highest.get(sender, -1), sequence)


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    # Copies and delays on the node's answers; no loss, so every read must succeed.
    options = ("--duplicate", "0.2", "--delay", "0.1", "--delay-time", "0.001")
    with adapter_bus("copies", 1, node_options=options) as running:
        with AdapterPort(running.name, root=running.root) as port:
            for k in range(WORDS):
                port.write_quadlet(0, 4 * k, word(k))
        yield running


@pytest.mark.process
def test_through_the_adapter_every_read_brings_its_own_word(bus: AdapterBus) -> None:
    wrong = 0
    with AdapterPort(bus.name, root=bus.root) as port:
        asked: list[tuple[int, int]] = []
        for i in range(READS + DEPTH):
            if i < READS:
                k = i % WORDS
                asked.append((k, port.start(Op.read, 0, 4 * k, length=4, quadlet=True)))
            if len(asked) >= DEPTH or i >= READS:
                if not asked:
                    break
                k, number = asked.pop(0)
                reply = port.wait(number)
                assert reply.status is Status.ok, reply
                wrong += int.from_bytes(reply.data, "big") != word(k)
    assert wrong == 0


@pytest.mark.process
def test_through_a_host_of_its_own_every_read_brings_its_own_word(bus: AdapterBus) -> None:
    wrong = 0
    with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as port:
        port.wait_ready()
        for start in range(0, READS, DEPTH):
            started = [
                (k % WORDS, port.start_read_quadlet(0, 4 * (k % WORDS)))
                for k in range(start, min(start + DEPTH, READS))
            ]
            for k, tid in started:
                event = port.wait(tid)
                assert not isinstance(event, TransactionFailed), event
                assert isinstance(event, ReadCompleted)
                wrong += int.from_bytes(event.data, "big") != word(k)
        copies = port.link.copies
    assert wrong == 0
    assert copies > 0  # the node's copies came, and were dropped


@pytest.mark.process
def test_answers_to_copies_of_requests_complete_nothing(bus: AdapterBus) -> None:
    """This host sends a fifth of its requests twice and frees a label the moment its
    transaction is answered: the node's answer to the copy is a frame of its own, but
    its ack names the copied request's frame, not the one the label went out in last."""
    wrong = 0
    faults = FaultConfig(duplicate=0.2, seed=26)
    with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0), faults=faults) as port:
        port.wait_ready()
        port.requester.duplicate_window = 0.0  # no hold: only the link tells copies apart
        for start in range(0, READS, DEPTH):
            started = [
                (k % WORDS, port.start_read_quadlet(0, 4 * (k % WORDS)))
                for k in range(start, min(start + DEPTH, READS))
            ]
            for k, tid in started:
                event = port.wait(tid)
                assert isinstance(event, ReadCompleted), event
                wrong += int.from_bytes(event.data, "big") != word(k)
        stale = port.link.stale_acks
    assert wrong == 0
    assert stale > 0  # answers to the copies came, and were dropped
