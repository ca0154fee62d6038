"""The host side of Eth1394, request by request as the JHU host library does it.

:class:`EthUdpClient` replays the library's port layer (EthUdpPort and
EthBasePort): the transaction label incremented before *every* request,
the control word (no-forward when asked or in Ethernet-only mode, the host's
bus generation), the destination choice (broadcast, multicast, per-board
unicast, hub unicast), the flush before each read, one receive of exactly
the expected size with a 20 ms timeout, the checks of :func:`host_verdict`,
and the bus-generation bookkeeping of the extra bytes. It logs what the
library would print.

One deliberate difference: the real host multicasts through its routing
table with the default TTL; this client sends multicast on loopback with
TTL 0, so its datagrams never leave the machine. It refuses non-loopback
server addresses.
"""

from __future__ import annotations

import functools
import select
import socket
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from fw1394.boards.qla1.eth_server import LOOPBACK_INTERFACE
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
)
from fw1394.packets.eth1394 import (
    BROADCAST_NODE,
    EXTRA_SIZE,
    HOST_RECEIVE_TIMEOUT_S,
    MULTICAST_GROUP,
    HostNodeFlag,
    HostReadRequest,
    HostVerdict,
    host_verdict,
)
from fw1394.packets.eth1394_fast import extra_generation_and_echo, request_datagram
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import LOCAL_BASE
from fw1394.transport.eth1394_addresses import (
    MULTICAST_FIRMWARE,
    Endpoint,
    classful_broadcast,
    offset_address,
    require_loopback,
)

#: The host's own node ID in every request: bus 0x3FF, node 16.
HOST_SOURCE_ID = 0xFFD0
LOCAL_BUS_IDS = LOCAL_BASE
TL_MASK = 0x3F  # not a node ID: tlabels are 6 bits too
MAX_BOARDS = 16
MAX_DATAGRAM = 65_535
#: How many of the latest datagrams :attr:`EthUdpClient.sent` keeps.
SENT_KEPT = 1024
#: What the host remembers of a read (the loop asks with the same few labels and sizes).
_host_read = functools.lru_cache(maxsize=1024)(HostReadRequest)
# Plain ints: flag arithmetic on the enum costs more than the rest of a send.
_NO_FORWARD = int(HostNodeFlag.NO_FORWARD)
_ETH_BROADCAST = int(HostNodeFlag.ETH_BROADCAST)


@dataclass
class ClientState:
    """What the library knows about the bus (EthBasePort / BasePort members)."""

    tl: int = 0
    generation: int = 0
    new_generation: int = 0
    use_bridge: bool = False
    hub_board: int = 0
    firmware: list[int] = field(default_factory=lambda: [0] * MAX_BOARDS)
    log: list[str] = field(default_factory=list)


class EthUdpClient:
    """A host port talking to ``endpoint`` (the server IP the host was given).

    ``force_bridge`` is the library's ``udpfw:`` spelling. ``log`` receives
    every message the library would print (default: kept in ``state.log``).
    """

    def __init__(
        self,
        endpoint: Endpoint,
        *,
        force_bridge: bool = False,
        receive_timeout: float = HOST_RECEIVE_TIMEOUT_S,
        log: Callable[[str], None] | None = None,
    ) -> None:
        self.server = require_loopback(endpoint.host)
        self.port = endpoint.port
        self.receive_timeout = receive_timeout
        self.state = ClientState(use_bridge=force_bridge)
        self._log = log
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)
        # Safety: multicast only through loopback and never routed (see module doc).
        loopback = socket.inet_aton(LOOPBACK_INTERFACE)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, loopback)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)
        sock.setblocking(False)
        self.sock = sock
        #: The wait for an answer, on this one socket, set up once (not per receive).
        self._readable = select.poll()
        self._readable.register(sock, select.POLLIN)
        #: The latest datagrams sent, oldest first: (destination address, payload), for
        #: tests and traces (bounded: a real-time loop sends thousands a second).
        self.sent: deque[tuple[tuple[str, int], bytes]] = deque(maxlen=SENT_KEPT)

    def close(self) -> None:
        self.sock.close()

    def __enter__(self) -> EthUdpClient:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def say(self, text: str) -> None:
        self.state.log.append(text)
        if self._log is not None:
            self._log(text)

    @property
    def ethernet_only(self) -> bool:
        return not self.state.use_bridge

    # -- PacketSend: where a request goes -----------------------------------------------
    def destination(self, node: int, eth_broadcast: bool) -> str:
        state = self.state
        hub_firmware = state.firmware[state.hub_board]
        if eth_broadcast:
            return classful_broadcast(self.server) if hub_firmware < 9 else MULTICAST_GROUP
        if state.use_bridge:
            offset = state.hub_board if hub_firmware >= MULTICAST_FIRMWARE else 0
            return offset_address(self.server, offset)
        if node < MAX_BOARDS:
            return offset_address(self.server, node)
        return MULTICAST_GROUP if node == BROADCAST_NODE else self.server

    def _send(self, packet: AsyncPacket, node: int, flags: int) -> bool:
        no_forward = bool(flags & _NO_FORWARD) or self.ethernet_only
        payload = request_datagram(no_forward, self.state.generation, encode_packet(packet))
        address = (self.destination(node, bool(flags & _ETH_BROADCAST)), self.port)
        self.sent.append((address, payload))
        try:
            self.sock.sendto(payload, address)
        except OSError as error:
            self.say(f"Send: failed to send: {error.strerror}")
            return False
        return True

    def _next_tl(self) -> int:
        self.state.tl = (self.state.tl + 1) & TL_MASK
        return self.state.tl

    def _generation_ok(self, node: int, caller: str) -> bool:
        state = self.state
        # Only the bridge checks generations, and never for broadcasts.
        if node == BROADCAST_NODE or not state.use_bridge:
            return True
        if state.generation != state.new_generation:
            self.say(
                f"{caller}: Firewire bus reset, old generation = {state.generation}, "
                f"new generation = {state.new_generation}"
            )
            return False
        return True

    # -- receiving --------------------------------------------------------------------------
    def flush(self) -> int:
        """Drop every datagram waiting; how many there were.

        Asks the socket's poll first: on an empty socket (the usual case) a failed
        receive would cost an exception as well as the system call.
        """
        count = 0
        while self._readable.poll(0):
            try:
                self.sock.recv(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return count
            count += 1
        return count

    def _receive(self, size: int) -> bytes | None:
        """One wait (poll) and one recv() of at most ``size`` bytes (longer ones are cut)."""
        if not self._readable.poll(1000.0 * self.receive_timeout):
            return None
        try:
            return self.sock.recv(size)
        except (BlockingIOError, InterruptedError):
            return None

    def _process_extra(self, datagram: bytes) -> None:
        generation, no_forward_echo = extra_generation_and_echo(datagram)
        # Every response updates the generation the FPGA reports; only those
        # without the no-forward echo are announced as a bus reset.
        self.state.new_generation = generation
        if generation != self.state.generation and not no_forward_echo:
            self.say(f"Firewire bus reset, FPGA = {generation}, PC = {self.state.generation}")

    def _read(self, request: HostReadRequest, caller: str) -> bytes | None:
        """Receive and judge the answer to the read just sent; its 1394 packet if accepted."""
        datagram = self._receive(request.expected_size)
        if datagram is None:
            return None
        if len(datagram) == EXTRA_SIZE:
            self.say("PacketReceive: only extra data")
            self._process_extra(datagram)
            return None
        if len(datagram) != request.expected_size:
            self.say(
                f"{caller}: failed to receive read response: return value = {len(datagram)}, "
                f"expected = {request.expected_size}"
            )
            return None
        self._process_extra(datagram)
        verdict = host_verdict(request, datagram)
        if verdict is not HostVerdict.ACCEPTED:
            self.say(f"{caller}: {verdict.value}")
            return None
        return datagram[: request.expected_size - EXTRA_SIZE]

    # -- node-level calls (EthBasePort::Read/WriteQuadletNode, Read/WriteBlockNode) --------
    def read_quadlet_node(self, node: int, offset: int, flags: int = 0) -> int | None:
        if not self._generation_ok(node, "ReadQuadlet"):
            return None
        flushed = self.flush()
        if flushed:
            self.say(f"ReadQuadlet: flushed {flushed} packets")
        tl = self._next_tl()
        request = QuadletReadRequest(
            destination_id=LOCAL_BUS_IDS | node, tlabel=tl, source_id=HOST_SOURCE_ID, offset=offset
        )
        if not self._send(request, node, flags):
            return None
        packet = self._read(_host_read(node, tl), "ReadQuadlet")
        return None if packet is None else int.from_bytes(packet[12:16], "big")

    def write_quadlet_node(self, node: int, offset: int, value: int, flags: int = 0) -> bool:
        if not self._generation_ok(node, "WriteQuadlet"):
            return False
        request = QuadletWriteRequest(
            destination_id=LOCAL_BUS_IDS | node,
            tlabel=self._next_tl(),
            source_id=HOST_SOURCE_ID,
            offset=offset,
            quadlet_data=value,
        )
        return self._send(request, node, flags)

    def read_block_node(
        self, node: int, offset: int, length: int, flags: int = 0, *, flush: bool = True
    ) -> bytes | None:
        if not self._generation_ok(node, "ReadBlock"):
            return None
        if flush:
            flushed = self.flush()
            if flushed:
                self.say(f"ReadBlock: flushed {flushed} packets")
        tl = self._next_tl()
        request = BlockReadRequest(
            destination_id=LOCAL_BUS_IDS | node,
            tlabel=tl,
            source_id=HOST_SOURCE_ID,
            offset=offset,
            data_length=length,
        )
        if not self._send(request, node, flags):
            return None
        packet = self._read(_host_read(node, tl, length), "ReadBlock")
        return None if packet is None else packet[20 : 20 + length]

    def write_block_node(self, node: int, offset: int, data: bytes, flags: int = 0) -> bool:
        if not data or len(data) % 4:
            self.say(f"WriteBlock: illegal size ({len(data)}), must be multiple of 4")
            return False
        if not self._generation_ok(node, "WriteBlock"):
            return False
        request = BlockWriteRequest(
            destination_id=LOCAL_BUS_IDS | node,
            tlabel=self._next_tl(),
            source_id=HOST_SOURCE_ID,
            offset=offset,
            data=data,
        )
        return self._send(request, node, flags)

    def receive_broadcast_response(self, tl: int, length: int) -> bytes | None:
        """Ethernet-only: the hub's unasked answer to a broadcast query (any source node)."""
        packet = self._read(_host_read(BROADCAST_NODE, tl, length), "ReceiveBroadcastRead")
        return None if packet is None else packet[20 : 20 + length]
