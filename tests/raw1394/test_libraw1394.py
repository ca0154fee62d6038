"""Real libraw1394 programs on the virtual bus, through fw1394's libraw1394.so.11.

The programs are not fw1394's: Debian's ``testlibraw`` (built against the
real libraw1394, never against fw1394), and ``exercise.c`` compiled here
against Debian's libraw1394 headers. What they print is checked against the
1394 and IEEE 1212 layouts written out below, not against fw1394's own code.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import crcmod
import pytest
from adapter_support import AdapterBus, adapter_bus

HEADER = Path("/usr/include/libraw1394/raw1394.h")
EXERCISE = Path(__file__).with_name("exercise.c")

pytestmark = [
    pytest.mark.process,
    pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed"),
    pytest.mark.skipif(not HEADER.exists(), reason="libraw1394-dev headers are not installed"),
]

#: IEEE 1212 CRC-16 (polynomial 0x1021, initial 0), over the quadlets a block header covers.
crc16 = crcmod.mkCrcFun(0x11021, initCrc=0, rev=False, xorOut=0)


@pytest.fixture(scope="module")
def cache(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A private cache: the library is built once for this module, from the source."""
    return tmp_path_factory.mktemp("cache")


def run_command(bus: AdapterBus, cache: Path, *program: str) -> list[str]:
    command = [str(Path(sys.executable).with_name("fw1394")), "run", "--name", bus.name, "--"]
    # The program's own network namespace: it cannot reach any address, only the
    # adapter's Unix socket (a path in the filesystem, not in the namespace).
    if shutil.which("unshare") and os.geteuid() == 0:
        command = ["unshare", "-n", *command]
    return [*command, *program]


def env(bus: AdapterBus, cache: Path) -> dict[str, str]:
    return {**bus.cli_env(), "XDG_CACHE_HOME": str(cache)}


def host_order(text: str) -> int:
    """A quadlet testlibraw printed from memory (bus byte order read as a host int)."""
    return int.from_bytes(int(text, 16).to_bytes(4, sys.byteorder), "big")


@pytest.mark.skipif(shutil.which("testlibraw") is None, reason="libraw1394-tools not installed")
@pytest.mark.slow
def test_testlibraw_passes_against_a_bus_of_qla1_boards(cache: Path) -> None:
    with adapter_bus("testlibraw", 2, board="qla1") as bus:
        result = subprocess.run(
            run_command(bus, cache, "stdbuf", "-o0", "testlibraw"),
            env=env(bus, cache),
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    out = result.stdout
    assert result.returncode == 0, result.stderr
    # One port: this bus, its two boards and the adapter as the local node and IRM.
    assert "1 card found" in out
    assert f"card 0, name: {bus.name}" in out
    assert "3 nodes on bus, local ID is 2, IRM is 2" in out
    # Config ROM reads (CSR 0x400) of every node, async and blocking: each first
    # quadlet is a ROM header with info_length 4 (IEEE 1212 8.2.3), and the two
    # passes read the same values.
    values = re.findall(r"read from node (\d)\.\.\. completed with value 0x([0-9a-f]{8})", out)
    assert [int(n) for n, _ in values] == [0, 1, 2, 0, 1, 2]
    headers = [host_order(v) for _, v in values]
    assert all(h >> 24 == 4 for h in headers)
    assert headers[:3] == headers[3:]
    # FCP: both writes to the local node's FCP registers reached the handler intact.
    # testlibraw writes FCP_COMMAND, then FCP_RESPONSE, to its own node.
    fcp = re.findall(r"got fcp (\w+) from node (\d+) of 8 bytes: ([0-9a-f ]+)", out)
    assert fcp == [
        ("command", "2", "01 23 45 67 89 ab cd ef"),
        ("response", "2", "01 23 45 67 89 ab cd ef"),
    ]
    assert "ERROR" not in out
    # Topology map: three self-ID packets (identifier 0b10), physical IDs 0, 1, 2.
    topology = re.search(r"topology map: (\d+) nodes, (\d+) self ids, generation (\d+)", out)
    assert topology is not None and topology.groups()[:2] == ("3", "3")
    self_ids = [int(x, 16) for x in re.findall(r"^    (0x[0-9a-f]{8})$", out, re.M)[:3]]
    assert [q >> 30 for q in self_ids] == [2, 2, 2]
    assert [(q >> 24) & 0x3F for q in self_ids] == [0, 1, 2]
    # The local configuration ROM: bus-info block "1394" whose CRC covers 4 quadlets.
    rom_line = re.search(r"get_config_rom returned 0, romsize (\d+), rom_version \d+", out)
    assert rom_line is not None and int(rom_line.group(1)) % 4 == 0
    after = out[rom_line.end() :]
    rom = [host_order(q) for q in re.findall(r"^    0x([0-9a-f]{8})$", after, re.M)[:10]]
    assert rom[1] == int.from_bytes(b"1394", "big")
    info = b"".join(q.to_bytes(4, "big") for q in rom[1:5])
    assert rom[0] >> 24 == 4 and rom[0] & 0xFFFF == crc16(info)
    # A unit directory added to the local ROM, then removed (testlibraw's own data).
    assert "added unit '0x58595a:0x616263', reverting in 5 seconds" in out
    assert "unit '0x58595a:0x616263' removed" in out
    # Cycle timer: seconds, cycles (< 8000), sub-cycle offsets (< 3072).
    cycles = re.findall(r"cycle timer: (\d+) seconds, (\d+) cycles, (\d+) sub-cycles", out)
    assert len(cycles) == 3
    assert all(int(c) < 8000 and int(s) < 3072 for _, c, s in cycles)
    # The echo request comes back through loop_iterate.
    assert "raw1394_loop_iterate() returned 0xdeadbeef" in out


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_exercise_program_under_valgrind(cache: Path, tmp_path: Path) -> None:
    program = tmp_path / "exercise"
    subprocess.run(
        ["gcc", "-g", "-Wall", "-o", str(program), str(EXERCISE), "-lraw1394"], check=True
    )
    valgrind = [
        "valgrind",
        "--quiet",
        "--error-exitcode=99",
        "--leak-check=full",
        "--errors-for-leak-kinds=definite,indirect",
        str(program),
    ]
    with adapter_bus("exercise", 3) as bus:
        process = subprocess.Popen(
            run_command(bus, cache, *valgrind),
            env=env(bus, cache),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        assert process.stdout is not None and process.stdin is not None
        lines = []
        try:
            for line in process.stdout:
                lines.append(line.rstrip("\n"))
                if line.startswith("kill node 0"):
                    os.kill(bus.bus.records()[0].pid, signal.SIGKILL)
                    process.stdin.write("\n")
                    process.stdin.flush()
                if line.startswith(("FAIL", "done")):
                    break
            rest, errors = process.communicate(timeout=120)
        finally:
            if process.poll() is None:
                process.kill()
                process.wait()
    lines += rest.splitlines()
    assert lines[-1] == "done", "\n".join(lines) + errors
    assert process.returncode == 0, errors  # 99: valgrind found leaks or bad accesses
    checks = {line.split(" ", 1)[1] for line in lines if line.startswith("ok ")}
    for name in (
        "64 outstanding complete",
        "get_fd readable while replies wait",
        "get_fd quiet once they are handled",
        "transactions end across a reset",
        "bus reset handler",
        "broadcast reached every node",
        "fcp handler",
        "read own ARM range",
        "arm notification",
        "lock own ARM range",
        "arm_register overlap refused",
        "async_stream",
        "stale generation fails",
        "update_generation",
        "read from a dead node fails",
        "reset after the death",
    ):
        assert name in checks


@pytest.mark.skipif(
    shutil.which("sendiso") is None or shutil.which("dumpiso") is None,
    reason="libraw1394-tools not installed",
)
def test_sendiso_into_dumpiso(cache: Path, tmp_path: Path) -> None:
    """Stream packets on channel 5 from one program to another, through the adapter."""
    # The isodump v2 format both tools use: a 32-byte header ("1394 isodump v2", then
    # the channel mask big-endian), then per packet u32 length (host order), channel,
    # tag, sy, a pad byte, and the payload.
    count, loops = 200, 4
    header = b"1394 isodump v2".ljust(16, b"\0") + (1 << 5).to_bytes(8, "big") + bytes(8)
    records = [
        struct.pack("=IBBBB", 8, 5, 1, i % 16, 0) + struct.pack(">II", 0xCAFE0000 + i, i)
        for i in range(count)
    ]
    sent, dumped = tmp_path / "sent.iso", tmp_path / "dumped.iso"
    sent.write_bytes(header + b"".join(records))
    with adapter_bus("iso", 1) as bus:
        dump = subprocess.Popen(
            run_command(bus, cache, "dumpiso", "-c", "5", str(dumped)),
            env=env(bus, cache),
            stderr=subprocess.PIPE,
        )
        try:
            limit = time.monotonic() + 30
            # dumpiso writes its header just before it starts listening; sendiso sends
            # the file several times, so the dump is a window of that stream.
            while not (dumped.exists() and dumped.stat().st_size >= len(header)):
                assert time.monotonic() < limit and dump.poll() is None, "dumpiso did not start"
                time.sleep(0.05)
            send = subprocess.run(
                run_command(bus, cache, "sendiso", "--loop", str(loops), str(sent)),
                env=env(bus, cache),
                capture_output=True,
                timeout=120,
                check=False,
            )
            assert send.returncode == 0, send.stderr
            # sendiso's close waits until the adapter has taken every packet: they are
            # all on their way to dumpiso, from the first one it was listening for.
            size = len(records[0])
            while dumped.stat().st_size < len(header) + size:
                assert time.monotonic() < limit, "no packet arrived"
                time.sleep(0.05)
            first = records.index(dumped.read_bytes()[len(header) : len(header) + size])
            expected = len(header) + size * (count * loops - first)
            limit = time.monotonic() + 30
            while dumped.stat().st_size < expected:
                assert time.monotonic() < limit, "the packets did not all arrive"
                time.sleep(0.05)
        finally:
            dump.terminate()
            dump.wait(10)
    data = dumped.read_bytes()
    assert data[: len(header)] == header
    got = [data[i : i + size] for i in range(len(header), len(data), size)]
    # Every packet arrived intact and in order from the first dumpiso listened for.
    assert first < count
    assert got == (records * loops)[first:]


def dynamic_symbols(library: Path) -> set[str]:
    out = subprocess.run(
        ["nm", "-D", "--defined-only", str(library)], capture_output=True, text=True, check=True
    ).stdout
    return {
        line.split()[-1] for line in out.splitlines() if line.split()[-1].startswith("raw1394_")
    }


@pytest.mark.skipif(
    shutil.which("nm") is None or shutil.which("readelf") is None, reason="binutils"
)
def test_library_has_debians_soname_and_exports(cache: Path) -> None:
    debian = Path("/usr/lib/x86_64-linux-gnu/libraw1394.so.11")
    if not debian.exists():
        pytest.skip("Debian's libraw1394.so.11 is not installed to compare with")
    built = subprocess.run(
        [str(Path(sys.executable).with_name("fw1394")), "libraw1394", "--path"],
        env={**os.environ, "XDG_CACHE_HOME": str(cache)},
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    library = Path(built)
    dynamic = subprocess.run(
        ["readelf", "-d", "--dyn-syms", str(library)], capture_output=True, text=True, check=True
    ).stdout
    assert "Library soname: [libraw1394.so.11]" in dynamic
    assert "@" not in "".join(line for line in dynamic.splitlines() if "raw1394_" in line)
    # Every function Debian's library offers programs (its raw1394_* exports), no more.
    assert dynamic_symbols(library) == dynamic_symbols(debian)
    assert len(dynamic_symbols(library)) == 68


#: Blocking block writes and reads to every node, each read checked against the write.
ROUND_TRIPS = r"""
#include <stdio.h>
#include <string.h>
#include <libraw1394/raw1394.h>
int main(void)
{
    raw1394handle_t h = raw1394_new_handle_on_port(0);
    quadlet_t out[4], in[4];
    int cycle, node, nodes;
    if (!h) { perror("raw1394_new_handle_on_port"); return 1; }
    nodes = raw1394_get_nodecount(h) - 1; /* the adapter, highest, is the last */
    for (cycle = 0; cycle < 200; cycle++)
        for (node = 0; node < nodes; node++) {
            memset(out, cycle * 7 + node, sizeof out);
            if (raw1394_write(h, 0xFFC0 | node, 0x40, sizeof out, out) < 0 ||
                raw1394_read(h, 0xFFC0 | node, 0x40, sizeof in, in) < 0) {
                perror("transaction"); return 1;
            }
            if (memcmp(in, out, sizeof in)) { printf("FAIL cycle %d\n", cycle); return 1; }
        }
    printf("done %d\n", nodes);
    raw1394_destroy_handle(h);
    return 0;
}
"""


#: System calls a program makes to wait: each one the trace shows counts.
WAITING_CALLS = ("send", "recv", "poll", "ppoll", "read", "sched_yield", "epoll_wait")


@pytest.mark.skipif(shutil.which("strace") is None, reason="strace is not installed")
def test_a_blocking_call_sleeps_until_its_reply_comes(cache: Path, tmp_path: Path) -> None:
    """A blocking read or write is a send, a poll that sleeps until the reply is
    there and a receive: no spinning (even where FW1394_IDLE asks the bus for it),
    no eventfd touched when nothing for loop_iterate changed; and no reply is lost
    or mixed up on the way."""
    source = tmp_path / "round_trips.c"
    source.write_text(ROUND_TRIPS)
    program = tmp_path / "round_trips"
    subprocess.run(["gcc", "-Wall", "-o", str(program), str(source), "-lraw1394"], check=True)
    trace = tmp_path / "trace"
    calls = ",".join(WAITING_CALLS) + ",sendto,recvfrom,sendmsg,recvmsg"
    with adapter_bus("waiting", 2) as bus:
        done = subprocess.run(
            run_command(bus, cache, "strace", "-o", str(trace), "-e", calls, str(program)),
            env={**env(bus, cache), "FW1394_IDLE": "spin"},
            capture_output=True,
            text=True,
            timeout=300,
        )
    assert (done.returncode, done.stdout) == (0, "done 2\n"), done.stderr
    made = [line.split("(", 1)[0] for line in trace.read_text().splitlines() if "(" in line]
    transactions = 200 * 2 * 2
    assert "sched_yield" not in made
    assert not [
        line
        for line in trace.read_text().splitlines()
        if "MSG_DONTWAIT" in line and line.startswith("recv")
    ]
    # Per transaction a send, a poll and a receive; the rest (connecting, hello,
    # the node count, the loader's reads) does not grow with the transactions.
    assert len(made) <= 3 * transactions + 60, sorted(set(made))
