"""An Eth1394 board addressed by quadlet index, with four planted defects, for fuzzing tests.

Written from the JHU Eth1394 description alone (standard library only, no
fw1394 code): a request datagram is a 2-byte control word and a 1394 request;
a read is answered with the response packet and 8 extra bytes, a write with
nothing. Only offset bits 15:0 are decoded, as a quadlet index (offset 4 is
register 4; a block advances one index per quadlet). The board is node 0 and
takes node 0 and broadcast (63) writes (an index past 0xFFFF wraps to 0); it
has 256 registers of one quadlet, all readable and writable except HARDWARE_VERSION (4, 'QLA1') and
FIRMWARE_VERSION (7, 9); reads beyond them return 0, writes are ignored.
Damaged packets (header or data CRC) are dropped, and so is everything but
quadlet and block reads and writes.

Defects, each switched on by its flag:

  --corrupt      a write to register 0x21 also overwrites register 0x31
  --other-node   packets for node 5 are taken as if they were for node 0
  --wedge        after a block read of 4096 bytes or more it never answers again
  --stuck-bit    register 0x1f loses bit 0 of a value whose bit 31 is set

    python jhu_defective_node.py PORT SECONDS [flags]   (prints "listening on HOST:PORT")
"""

import socket
import struct
import sys
import time

REGISTERS = 0x100
READ_ONLY = {4: 0x514C4131, 7: 9}
CORRUPTING, CORRUPTED = 0x21, 0x31
ALSO_MINE = 5
STUCK = 0x1F
WEDGE_BYTES = 4096


def crc32(data: bytes) -> int:
    # CRC-32/BZIP2: poly 0x04C11DB7, MSB first, initial value and final XOR all ones.
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1) & 0xFFFFFFFF
    return crc ^ 0xFFFFFFFF


class Board:
    def __init__(self, flags: set[str]) -> None:
        self.flags = flags
        self.registers = [0] * REGISTERS
        self.registers[0xB] = 0xFFFFFFFF  # IP_ADDR: unassigned
        self.wedged = False

    def read(self, index: int) -> int:
        index &= 0xFFFF
        if index in READ_ONLY:
            return READ_ONLY[index]
        return self.registers[index] if index < REGISTERS else 0

    def write(self, index: int, value: int) -> None:
        index &= 0xFFFF
        if index >= REGISTERS or index in READ_ONLY:
            return
        if index == STUCK and "--stuck-bit" in self.flags and value & 0x80000000:
            value &= ~1
        self.registers[index] = value
        if index == CORRUPTING and "--corrupt" in self.flags:
            self.registers[CORRUPTED] = value ^ 0xFFFF0000

    def handle(self, packet: bytes) -> bytes | None:
        """The response datagram for one 1394 request, or None."""
        if self.wedged or len(packet) < 16:
            return None
        q0, q1, q2 = struct.unpack(">III", packet[:12])
        destination, tlabel, tcode = q0 >> 16, (q0 >> 10) & 0x3F, (q0 >> 4) & 0xF
        node = destination & 0x3F
        if "--other-node" in self.flags and node == ALSO_MINE:
            node = 0
        source, index = q1 >> 16, q2 & 0xFFFF
        if tcode == 4:  # quadlet read: Q0-Q2 and the header CRC
            if len(packet) != 16 or node != 0 or crc32(packet[:12]) != _quadlet(packet, 12):
                return None
            return self.response(source, tlabel, 6, [0, self.read(index)])
        if len(packet) < 20 or crc32(packet[:16]) != _quadlet(packet, 16):
            return None
        if tcode == 0:  # quadlet write: the value in Q3, under the header CRC
            if len(packet) == 20 and node in (0, 63):
                self.write(index, _quadlet(packet, 12))
            return None
        length = _quadlet(packet, 12) >> 16
        quadlets = (length + 3) // 4
        if tcode == 5:  # block read: one index per quadlet
            if len(packet) != 20 or node != 0:
                return None
            if length >= WEDGE_BYTES and "--wedge" in self.flags:
                self.wedged = True
                return None
            words = b"".join(struct.pack(">I", self.read(index + n)) for n in range(quadlets))
            data = words[:length] + bytes(-length % 4)
            head = struct.pack(
                ">IIII", source << 16 | tlabel << 10 | 7 << 4, 0xFFC0 << 16, 0, length << 16
            )
            return (
                head
                + struct.pack(">I", crc32(head))
                + data
                + struct.pack(">I", crc32(data))
                + bytes(8)
            )
        if tcode == 1:  # block write: data padded to quadlets, then its CRC
            if len(packet) != 24 + 4 * quadlets or node not in (0, 63):
                return None
            data = packet[20 : 20 + 4 * quadlets]
            if crc32(data) != _quadlet(packet, 20 + 4 * quadlets):
                return None
            for n in range(length // 4):
                self.write(index + n, _quadlet(data, 4 * n))
        return None

    def response(self, destination: int, tlabel: int, tcode: int, quadlets: list[int]) -> bytes:
        body = struct.pack(
            f">{2 + len(quadlets)}I",
            destination << 16 | tlabel << 10 | tcode << 4,
            0xFFC0 << 16,
            *quadlets,
        )
        return body + struct.pack(">I", crc32(body)) + bytes(8)


def _quadlet(data: bytes, at: int) -> int:
    value: int = struct.unpack(">I", data[at : at + 4])[0]
    return value


def main() -> None:
    port, seconds, flags = int(sys.argv[1]), float(sys.argv[2]), set(sys.argv[3:])
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", port))
    sock.settimeout(0.2)
    print(f"listening on 127.0.0.1:{sock.getsockname()[1]}", flush=True)
    board = Board(flags)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            datagram, peer = sock.recvfrom(65535)
        except TimeoutError:
            continue
        answer = board.handle(datagram[2:])
        if answer is not None:
            sock.sendto(answer, peer)


if __name__ == "__main__":
    main()
