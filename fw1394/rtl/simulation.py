"""Compile a link design behind the harness and run it in Icarus Verilog with cocotb.

:class:`Simulation` is the parent's end: it builds the design (iverilog, once
per port map and defines, in a cache directory), starts ``vvp`` with cocotb's
VPI module as a child process running :mod:`fw1394.rtl.cocotb_node`, and
talks to it over a loopback TCP socket, one JSON line per request. A child
that dies or stops answering is reported as :class:`SimulationError`.
"""

from __future__ import annotations

import atexit
import hashlib
import json
import os
import select
import shutil
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from fw1394.errors import Error
from fw1394.rtl.portmap import HDL_DIR, PortMap, harness_verilog
from fw1394.transport.supervision.stop import stop

#: Verdicts never depend on wall time: the PHY model bounds every wait in clock
#: cycles ([phy] in the port map), and the parent waits for the simulator as long
#: as it lives. Only a simulator that makes no progress at all this many seconds
#: (a zero-delay loop in the design, say) is given up on.
STUCK_AFTER = 600.0
#: Seconds between two looks at whether the simulator still lives.
_POLL = 1.0


class SimulationError(Error, RuntimeError):
    """The simulator is missing, failed to build, died or stopped answering."""


def missing_tools() -> str | None:
    """Why RTL simulation cannot run here (None: it can)."""
    for tool in ("iverilog", "vvp"):
        if shutil.which(tool) is None:
            return f"{tool} (Icarus Verilog) is not installed"
    try:
        import cocotb  # noqa: F401
        import cocotb_tools.config  # noqa: F401
    except ImportError:
        return "cocotb is not installed (pip install 'fw1394[rtl]')"
    return None


def cache_dir() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fw1394" / "rtl"


def build(portmap: PortMap, *, defines: tuple[str, ...] = (), waves: Path | None = None) -> Path:
    """The compiled simulation (a vvp file) of the design behind the harness."""
    problem = missing_tools()
    if problem:
        raise SimulationError(problem)
    harness = harness_verilog(portmap)
    sources = [str(s) for s in portmap.sources]
    all_defines = (*portmap.defines, *defines)
    dump = ""
    if waves is not None:
        dump = (
            "`timescale 1ns/1ps\nmodule fw1394_dump;\ninitial begin\n"
            f'    $dumpfile("{waves}");\n    $dumpvars(0, fw1394_harness);\nend\nendmodule\n'
        )
    key = hashlib.sha256()
    for part in (harness, dump, *all_defines):
        key.update(part.encode() + b"\0")
    for source in portmap.sources:
        key.update(source.read_bytes())
    for include in sorted(HDL_DIR.glob("*.vh")):
        key.update(include.read_bytes())
    directory = cache_dir() / key.hexdigest()[:20]
    target = directory / "sim.vvp"
    if target.exists():
        return target
    directory.mkdir(parents=True, exist_ok=True)
    (directory / "fw1394_harness.v").write_text(harness)
    extra = [str(directory / "fw1394_harness.v")]
    roots = ["-s", "fw1394_harness"]
    if dump:
        (directory / "fw1394_dump.v").write_text(dump)
        extra.append(str(directory / "fw1394_dump.v"))
        roots += ["-s", "fw1394_dump"]
    includes = sorted({str(HDL_DIR), *(str(s.parent) for s in portmap.sources)})
    command = [
        "iverilog",
        "-g2012",
        "-o",
        str(directory / "partial.vvp"),
        *roots,
        *(f"-I{path}" for path in includes),
        *(f"-D{name}" for name in all_defines),
        *sources,
        *extra,
    ]
    result = subprocess.run(command, capture_output=True, text=True)
    if result.returncode != 0:
        lines = (result.stderr or result.stdout).strip().splitlines()
        raise SimulationError(f"iverilog failed: {lines[0] if lines else 'no output'}")
    (directory / "partial.vvp").replace(target)
    return target


def _cocotb_environment(config: dict[str, Any]) -> dict[str, str]:
    import cocotb_tools.config
    import find_libpython

    env = dict(os.environ)
    libpython = find_libpython.find_libpython()
    if libpython is None:
        raise SimulationError("cocotb cannot find libpython for this interpreter")
    env.update(
        {
            "COCOTB_TEST_MODULES": "fw1394.rtl.cocotb_node",
            "COCOTB_TOPLEVEL": "fw1394_harness",
            "TOPLEVEL_LANG": "verilog",
            "PYGPI_PYTHON_BIN": sys.executable,
            "GPI_USERS": f"{libpython};{cocotb_tools.config.pygpi_entry_point()}",
            "PYTHONPATH": os.pathsep.join(p for p in sys.path if p),
            "COCOTB_RESULTS_FILE": os.devnull,
            "COCOTB_LOG_LEVEL": "WARNING",
            "FW1394_RTL_CONFIG": json.dumps(config),
        }
    )
    return env


class Simulation:
    """One running simulation of ``portmap``'s design with the PHY model on its pins."""

    def __init__(
        self,
        portmap: PortMap,
        *,
        physical_id: int,
        board_id: int = 0,
        defines: tuple[str, ...] = (),
        board_defects: tuple[str, ...] = (),
        waves: Path | None = None,
        stuck_after: float = STUCK_AFTER,
        sclk_mhz: float = 49.152,
        every_cycle: bool = False,
    ) -> None:
        """``every_cycle``: the PHY model steps every SCLK cycle from Python instead of
        letting the simulator run between events (slow; the reference the fast way
        is checked against)."""
        import cocotb_tools.config

        self.portmap = portmap
        self.stuck_after = stuck_after
        #: What a simulation must match to be used again (see :func:`start`).
        self.key = _key(
            portmap,
            {
                "physical_id": physical_id,
                "board_id": board_id,
                "defines": defines,
                "board_defects": board_defects,
                "sclk_mhz": sclk_mhz,
                "every_cycle": every_cycle,
            },
        )
        self.waves = waves
        self._owner = os.getpid()
        fst = waves is not None and waves.suffix == ".fst"
        vvp = build(portmap, defines=defines, waves=waves)
        listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        listener.bind(("127.0.0.1", 0))
        listener.listen(1)
        config = {
            "port": listener.getsockname()[1],
            "portmap": str(portmap.path),
            "physical_id": physical_id,
            "board_id": board_id,
            "defects": list(board_defects),
            "sclk_mhz": sclk_mhz,
            "every_cycle": every_cycle,
        }
        # The simulator's own output, kept for the error message if it dies.
        self._log = tempfile.TemporaryFile()  # noqa: SIM115
        command = ["vvp", "-m", str(cocotb_tools.config.lib_entry("vpi", "icarus"))]
        # vvp's extended arguments: -none turns dumping off, -fst picks FST over VCD.
        command += [str(vvp)] + (["-none"] if waves is None else ["-fst"] if fst else [])
        self.process = subprocess.Popen(
            command,
            env=_cocotb_environment(config),
            stdin=subprocess.DEVNULL,
            stdout=self._log,
            stderr=subprocess.STDOUT,
            cwd=str(vvp.parent),
        )
        listener.settimeout(_POLL)
        deadline = time.monotonic() + stuck_after
        try:
            while True:
                try:
                    self.sock, _ = listener.accept()
                    break
                except TimeoutError:
                    if self.alive() and time.monotonic() < deadline:
                        continue
                    tail = self.log_tail()
                    self.close()
                    raise SimulationError(f"the simulator did not start: {tail}") from None
        finally:
            listener.close()
        self.sock.settimeout(None)
        self.stream = self.sock.makefile("rwb")
        hello = self._receive()
        #: The design acknowledged a valid quadlet read after reset.
        self.acked: bool = hello["acked"]
        #: What the PHY saw during reset and that read (see :func:`fw1394.rtl.refusal`).
        self.probe: dict[str, Any] = hello.get("probe", {})

    def _receive(self) -> dict[str, Any]:
        # Wait while the simulator lives, however slowly the machine runs it; it
        # answers each request with one whole line (or dies, closing the socket).
        deadline = time.monotonic() + self.stuck_after
        try:
            while not select.select([self.sock], [], [], _POLL)[0]:
                if time.monotonic() > deadline:
                    raise SimulationError(
                        f"the simulator made no progress in {self.stuck_after:.0f} s"
                    )
            line = self.stream.readline()
        except OSError as error:
            raise SimulationError(f"the simulator's socket failed: {error}") from None
        if not line:
            self.process.wait(5)
            raise SimulationError(
                f"the simulator exited ({self.process.returncode}): {self.log_tail()}"
            )
        message: dict[str, Any] = json.loads(line)
        return message

    def request(self, message: dict[str, Any]) -> dict[str, Any]:
        try:
            self.stream.write(json.dumps(message).encode() + b"\n")
            self.stream.flush()
        except OSError as error:
            raise SimulationError(f"the simulator is gone: {error}") from None
        return self._receive()

    def exchange(
        self,
        packets: list[bytes],
        now: float,
        *,
        interrupting: int = 0,
        speeds: list[int] | None = None,
    ) -> dict[str, Any]:
        """Deliver ``packets``; ``interrupting``: each cuts a status transfer after N cycles;
        ``speeds``: each packet's speed (0 S100, 1 S200, 2 S400; default S400)."""
        message: dict[str, Any] = {
            "op": "exchange",
            "now": now,
            "packets": [p.hex() for p in packets],
        }
        if interrupting:
            message["interrupting"] = interrupting
        if speeds is not None:
            message["speeds"] = speeds
        return self.request(message)

    def restart(self, *, check: bool = False) -> bool:
        """Reset the design and the board behind it; ``check``: then see whether it acks
        a valid read, as a fresh start does (:attr:`acked`, :attr:`probe`)."""
        answer = self.request({"op": "restart", "check": check})
        if check:
            self.acked, self.probe = answer["acked"], answer["probe"]
        acked: bool = answer["acked"]
        return acked

    def bus_reset(self, physical_id: int) -> None:
        """A bus reset that gives the node ``physical_id`` (the PHY tells the link)."""
        self.request({"op": "bus_reset", "physical_id": physical_id})

    def log_tail(self) -> str:
        self._log.seek(0)
        text = self._log.read().decode(errors="replace").strip().splitlines()
        return text[-1] if text else "no output"

    def alive(self) -> bool:
        return self.process.poll() is None

    def close(self) -> None:
        try:
            if hasattr(self, "stream"):
                self.stream.write(b'{"op": "close"}\n')
                self.stream.flush()
        except OSError:
            pass
        stop(self.process, ask=None)  # asked by the "close" message
        if hasattr(self, "sock"):
            self.sock.close()
        self._log.close()


# -- simulations used again -------------------------------------------------------------
#: Simulations whose campaign ended, kept to start the next campaign of the same build
#: and options at once: a process that runs campaign after campaign (a Dask worker,
#: a shrinker's replays) would otherwise pay vvp's and cocotb's start-up, more CPU
#: than hundreds of cases, every time. A few at most, each reset before it is used.
_PARKED: list[Simulation] = []
_PARKED_AT_MOST = 2


def _key(portmap: PortMap, options: dict[str, Any]) -> tuple[Any, ...]:
    given = {**_KEYED, **{k: v for k, v in options.items() if k in _KEYED}}
    return (portmap, *(tuple(v) if isinstance(v, (list, tuple)) else v for v in given.values()))


#: The options that make two simulations different, with their defaults.
_KEYED: dict[str, Any] = {
    "physical_id": 0,
    "board_id": 0,
    "defines": (),
    "board_defects": (),
    "sclk_mhz": 49.152,
    "every_cycle": False,
}


def start(portmap: PortMap, **options: Any) -> Simulation:
    """A simulation of ``portmap`` as ``Simulation(portmap, **options)`` starts it: a
    parked one of the same build and options, reset and checked again, if any."""
    if options.get("waves") is None:
        key = _key(portmap, options)
        for sim in _PARKED:
            if sim.key == key:
                _PARKED.remove(sim)
                try:
                    sim.restart(check=True)
                    return sim
                except SimulationError:
                    sim.close()
                    break
    return Simulation(portmap, **options)


def park(sim: Simulation) -> None:
    """Give back ``sim`` when its campaign ends: kept for :func:`start`, or closed."""
    if sim.waves is not None or sim._owner != os.getpid() or not sim.alive():
        sim.close()
        return
    _PARKED.append(sim)
    while len(_PARKED) > _PARKED_AT_MOST:
        _PARKED.pop(0).close()


@atexit.register
def _close_parked() -> None:
    while _PARKED:
        sim = _PARKED.pop()
        if sim._owner == os.getpid():  # (a forked child leaves its parent's alone)
            sim.close()
