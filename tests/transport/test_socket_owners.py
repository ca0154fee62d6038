"""Who opens sockets: the media, the Eth1394 servers and clients, and a named few more.

The import-linter contract ``transport-sans-io`` keeps the bus's rules from
importing ``socket`` at all; this test keeps the list of modules that *open*
one (call ``socket.socket`` and its kin) short and honest. A new module that
opens a socket must be added here with its reason; a module that stops doing
so must be taken off.
"""

from __future__ import annotations

import ast
from pathlib import Path

import fw1394

OPENERS = {"socket", "create_connection", "create_server", "socketpair", "fromfd"}

# module -> why it opens sockets
OWNERS = {
    # the media
    "fw1394/transport/media/udp.py": "the UDP multicast medium",
    "fw1394/transport/media/shared_memory.py": "the ring's doorbells (Unix datagram sockets)",
    # the Eth1394 world: the boards' server and the host library's client
    "fw1394/boards/qla1/eth_server.py": "the emulated boards' Eth1394 UDP server",
    "fw1394/jhu/client.py": "the Eth1394 host client",
    "fw1394/transport/udp_ports.py": "a probe that tells whether an Eth1394 server's port is taken",
    # the rest, each a protocol of its own
    "fw1394/transport/host_adapter/server.py": "the host adapter's Unix socket (adapter.sock)",
    "fw1394/host/adapter_port.py": "the host adapter's client end",
    "fw1394/capture/formats/live.py": "capturing a real interface (AF_PACKET)",
    "fw1394/fuzz/serve.py": "a fuzz target served over UDP",
    "fw1394/fuzz/udptarget.py": "fuzzing a target over UDP",
    "fw1394/fuzz/cluster.py": "a probe that a Dask scheduler listens before its client waits",
    "fw1394/rtl/simulation.py": "the HDL simulator's control connection (listening end)",
    "fw1394/rtl/cocotb_node.py": "the HDL simulator's control connection (inside the simulator)",
    "fw1394/experiments/baseline.py": "the raw UDP ping-pong every benchmark is compared against",
}


def socket_openers(root: Path) -> set[str]:
    """Modules under ``root`` that call ``socket.<opener>(...)``."""
    found = set()
    for path in root.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if (
                isinstance(node, ast.Call)
                and isinstance(node.func, ast.Attribute)
                and node.func.attr in OPENERS
                and isinstance(node.func.value, ast.Name)
                and node.func.value.id == "socket"
            ):
                found.add(path.relative_to(root.parent).as_posix())
                break
            if (
                isinstance(node, ast.ImportFrom)
                and node.module == "socket"
                and any(alias.name in OPENERS for alias in node.names)
            ):
                found.add(path.relative_to(root.parent).as_posix())
                break
    return found


def test_only_the_named_modules_open_sockets() -> None:
    assert socket_openers(Path(fw1394.__file__).parent) == set(OWNERS)


def test_the_scan_sees_both_spellings(tmp_path: Path) -> None:
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "plain.py").write_text("import socket\ns = socket.socket()\n")
    (package / "named.py").write_text("from socket import create_connection\n")
    (package / "typed.py").write_text("import socket\ndef f(s: socket.socket) -> None: ...\n")
    assert socket_openers(package) == {"pkg/plain.py", "pkg/named.py"}
