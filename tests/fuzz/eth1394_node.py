"""A small Eth1394 node with switchable contract violations, for fuzzing tests.

Written from the IEEE 1394 packet formats and the JHU Eth1394 framing alone
(a 2-byte control word before each request; responses to reads followed by 8
extra bytes; nothing back for writes), standard library only, sharing no code
with fw1394. It serves 64 KiB of byte-addressed memory as node 0 of any bus
and keeps the thesis contract (drop what is damaged or not for node 0, no
locks, silence on address errors) except where a flag says otherwise:

  --wedge          stop answering after a block write longer than 2048 bytes
  --other-nodes    answer reads addressed to other node numbers
  --bad-crc-reads  answer reads whose header CRC is wrong
  --side-effect    a quadlet write to register 0x10 also flips register 0x24

    python eth1394_node.py PORT SECONDS [flags]   (prints "listening on HOST:PORT")
"""

import socket
import struct
import sys
import time

SIZE = 0x10000
SIDE_A, SIDE_B = 0x10, 0x24


def crc32(data: bytes) -> int:
    # CRC-32 over big-endian bytes, MSB first, poly 0x04C11DB7, init and xorout all ones.
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = ((crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1) & 0xFFFFFFFF
    return crc ^ 0xFFFFFFFF


def sealed(quadlets: list[int]) -> bytes:
    body = struct.pack(f">{len(quadlets)}I", *quadlets)
    return body + struct.pack(">I", crc32(body))


class Node:
    def __init__(self, flags: set[str]) -> None:
        self.flags = flags
        self.memory = bytearray(SIZE)
        self.wedged = False

    def handle(self, packet: bytes) -> bytes | None:
        """The response datagram for one request packet, or None."""
        if self.wedged or len(packet) < 16:
            return None
        q0, q1, q2 = struct.unpack(">III", packet[:12])
        destination, tlabel, tcode = q0 >> 16, (q0 >> 10) & 0x3F, (q0 >> 4) & 0xF
        node = destination & 0x3F
        mine = node == 0 or (node != 63 and "--other-nodes" in self.flags)
        source, offset = q1 >> 16, (q1 & 0xFFFF) << 32 | q2
        if tcode == 4:  # quadlet read: Q0-Q2 and the header CRC
            good = len(packet) == 16 and crc32(packet[:12]) == struct.unpack(">I", packet[12:16])[0]
            answered = good or ("--bad-crc-reads" in self.flags and len(packet) == 16)
            if not mine or not answered:
                return None
            if offset % 4 or offset + 4 > SIZE:
                return None
            data = struct.unpack(">I", self.memory[offset : offset + 4])[0]
            return self.response(source, tlabel, 6, [0, data])
        if len(packet) < 20:
            return None
        q3, header_crc = struct.unpack(">II", packet[12:20])
        read_anyway = tcode == 5 and "--bad-crc-reads" in self.flags
        if crc32(packet[:16]) != header_crc and not read_anyway:
            return None
        if tcode == 0:  # quadlet write: the data in Q3, under the header CRC
            if len(packet) != 20 or node not in (0, 63):
                return None
            if offset % 4 == 0 and offset + 4 <= SIZE:
                self.memory[offset : offset + 4] = packet[12:16]
                if offset == SIDE_A and "--side-effect" in self.flags:
                    flipped = bytes(b ^ 0xFF for b in self.memory[SIDE_B : SIDE_B + 4])
                    self.memory[SIDE_B : SIDE_B + 4] = flipped
            return None
        length = q3 >> 16
        if tcode == 5:  # block read
            if len(packet) != 20 or not mine or offset + length > SIZE:
                return None
            data = bytes(self.memory[offset : offset + length])
            padded = data + bytes(-length % 4)
            head = self.response(source, tlabel, 7, [0, length << 16])[:-8]
            return head + padded + struct.pack(">I", crc32(padded)) + bytes(8)
        if tcode == 1:  # block write: data padded to quadlets, then its CRC
            padded = length + (-length % 4)
            if len(packet) != 24 + padded or node not in (0, 63):
                return None
            data = packet[20 : 20 + padded]
            if crc32(data) != struct.unpack(">I", packet[20 + padded :])[0]:
                return None
            if length > 2048 and "--wedge" in self.flags:
                self.wedged = True
            if length <= 2048 and offset + length <= SIZE:
                self.memory[offset : offset + length] = data[:length]
        return None  # locks, responses, streams and unknown tcodes: silence

    def response(self, destination: int, tlabel: int, tcode: int, quadlets: list[int]) -> bytes:
        first = destination << 16 | tlabel << 10 | tcode << 4
        # From node 0 on the local bus, rcode complete; 8 extra bytes follow.
        return sealed([first, 0xFFC0 << 16, *quadlets]) + bytes(8)


def main() -> None:
    port, seconds, flags = int(sys.argv[1]), float(sys.argv[2]), set(sys.argv[3:])
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", port))
    sock.settimeout(0.2)
    print(f"listening on 127.0.0.1:{sock.getsockname()[1]}", flush=True)
    node = Node(flags)
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            datagram, peer = sock.recvfrom(65535)
        except TimeoutError:
            continue
        answer = node.handle(datagram[2:])
        if answer is not None:
            sock.sendto(answer, peer)


if __name__ == "__main__":
    main()
