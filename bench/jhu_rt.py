"""The JHU real-time loop against ``fw1394 jhu serve``: rates beside the machine's floor.

For each board count, a fresh server and ``fw1394 jhu rt --json``: the loop's
rate is printed beside raw UDP ping-pongs to the same server, interleaved in
the same run (the floor the loop cannot beat right now), with the CPU time
per cycle of the client and of the server (from /proc) and the load average,
since the machine may be shared.

Firmware 9 (Ethernet-only, multicast) needs a network namespace whose multicast
route is on lo: run as root and this script makes one per run (``unshare -n``);
otherwise it falls back to firmware 8 (bridge mode) on an unprivileged port.

    sudo python bench/jhu_rt.py --boards 1 4 8 --cycles 2000
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import textwrap

CLOCK_TICKS = os.sysconf("SC_CLK_TCK")

RUN = textwrap.dedent(
    """
    import json, os, subprocess, sys, time
    boards, firmware, port, cycles, protocol = sys.argv[1:6]
    if firmware == "9":
        subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
        subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    cli = [sys.executable, "-m", "fw1394.cli.main", "jhu"]
    server = subprocess.Popen(cli + ["serve", "--boards", boards, "--firmware", firmware,
                                     "--eth1394", f"127.0.0.1:{port}"],
                              stderr=subprocess.PIPE, text=True)
    server.stderr.readline()

    def cpu(pid):
        fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    args = ["rt", "-p", f"udp:127.0.0.1:{port}", "--json", "--receive-timeout", "0.2",
            "--cycles", cycles]
    if protocol:
        args += ["--protocol", protocol]
    before = cpu(server.pid)
    host = subprocess.run(cli + args, capture_output=True, text=True)
    after = cpu(server.pid)
    server.terminate()
    server.wait()
    report = json.loads(host.stdout)
    # The server also served the scan (a few ms): a small overestimate.
    report["server_cpu_ms_per_cycle"] = 1e3 * (after - before) / int(cycles)
    report["firmware"] = int(firmware)
    print(json.dumps(report))
    """
)


def run(boards: int, cycles: int, protocol: str | None, namespace: bool) -> dict[str, object]:
    firmware, port = ("9", "1394") if namespace else ("8", "21394")
    command = [sys.executable, "-c", RUN, str(boards), firmware, port, str(cycles), protocol or ""]
    if namespace:
        command = ["unshare", "-n", *command]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600)
    if done.returncode != 0:
        raise SystemExit(f"run with {boards} boards failed: {done.stderr.strip()}")
    result: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=int, nargs="+", default=[1, 4, 8])
    parser.add_argument("--cycles", type=int, default=2000)
    parser.add_argument("--protocol", default="broadcast-read-write")
    args = parser.parse_args()
    namespace = os.geteuid() == 0 and shutil.which("unshare") is not None
    print(f"{'boards':>6} {'fw':>3} {'loop Hz':>8} {'ping Hz':>8} {'ratio':>6} "
          f"{'client ms':>9} {'server ms':>9} {'load':>5}")  # fmt: skip
    for boards in args.boards:
        r = run(boards, args.cycles, args.protocol, namespace)
        ratio = float(r["loop_hz"]) / float(r["ping_pong_hz"])  # type: ignore[arg-type]
        print(
            f"{boards:>6} {r['firmware']:>3} {float(r['loop_hz']):>8.0f} "  # type: ignore[arg-type]
            f"{float(r['ping_pong_hz']):>8.0f} {ratio:>6.2f} "  # type: ignore[arg-type]
            f"{float(r['client_cpu_ms_per_cycle']):>9.3f} "  # type: ignore[arg-type]
            f"{float(r['server_cpu_ms_per_cycle']):>9.3f} {float(r['load_1min']):>5.1f}"  # type: ignore[arg-type]
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
