"""``fw1394 bench`` end to end: the quick run, a bus target, an Eth1394 target, and user errors."""

from __future__ import annotations

import json
import threading
import time
from collections.abc import Iterator
from typing import Any

import pytest
from bus_support import bus_name, processes_mentioning, wait_until_gone
from udp_ports_support import quiet_udp_port

from fw1394.boards.qla1.eth_server import Eth1394Server
from fw1394.boards.qla1.rack import Rack
from fw1394.cli.bench import size_list
from fw1394.cli.common import CliError
from fw1394.cli.main import main
from fw1394.experiments.connect import TargetSpec, parse_target
from fw1394.experiments.regime import settle_time
from fw1394.experiments.report_text import render
from fw1394.experiments.timing import SWITCH_WARMUP
from fw1394.transport.eth1394_addresses import Endpoint
from fw1394.transport.media.idle import default_idle
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

SMALL = ["--iterations", "300", "--sizes", "1,8,64,512", "--passes", "2", "--quiet", "--json"]
PORT = quiet_udp_port()


def bench(capsys: pytest.CaptureFixture[str], *argv: str) -> dict[str, Any]:
    assert main(["bench", *argv]) == 0
    result: dict[str, Any] = json.loads(capsys.readouterr().out)
    return result


def check_quadlets(result: dict[str, Any], iterations: int) -> None:
    unit = result["baseline"]["round_trip"]["p50_us"]
    assert unit > 0
    for name in ("read", "write"):
        row = result["quadlet"][name]
        assert row["count"] == iterations
        assert 0 < row["min_us"] <= row["p50_us"] <= row["p90_us"] <= row["p99_us"] <= row["max_us"]
        # Every ratio is the figure over the raw round trip of the same run.
        for key in ("mean", "p50", "p90", "p99"):
            assert row[f"x_{key}"] == pytest.approx(row[f"{key}_us"] / unit, abs=0.01, rel=0.01)
        assert row["bands"] and sum(band["count"] for band in row["bands"]) == iterations


@pytest.mark.process
@pytest.mark.slow
def test_quick_run_on_a_fresh_virtual_bus(capsys: pytest.CaptureFixture[str]) -> None:
    started = time.monotonic()
    result = bench(capsys, "--quick", "--json", "--quiet")
    elapsed = time.monotonic() - started
    assert result["target"] == {
        "kind": "virtual-bus",
        "bus": result["target"]["bus"],
        "node": 0,
        "board": "snake2010",
        "writes_acknowledged": True,
    }
    assert result["settings"]["quadlet_iterations"] == 1000
    check_quadlets(result, 1000)
    block = result["block"]
    assert block["sizes"] == [1, 2, 4, 8, 16, 32, 64, 128, 256, 512]
    block_unit = block["raw_round_trip_p50_us"]
    for name in ("read", "write"):
        fit = block[name]
        assert fit["base_us"] > 0 and fit["points"] == 10 and fit["samples_per_size"] == 20
        assert fit["x_base"] == pytest.approx(fit["base_us"] / block_unit, abs=0.01, rel=0.01)
        assert len(fit["median_us"]) == 10 and min(fit["median_us"]) > 0
        assert fit["x_512"] == pytest.approx(
            fit["p50_512_us"] / block["raw_block_round_trip_p50_us"], rel=0.01
        )
    servo = result["servo"]
    means = result["quadlet"]["read"]["mean_us"] + result["quadlet"]["write"]["mean_us"]
    assert servo["quadlet"]["cycle_us"] == pytest.approx(7 * means, abs=0.2)
    for method in ("quadlet", "block"):
        cycle, left = servo[method]["cycle_us"], servo[method]["left_us"]
        assert left["1000"] == pytest.approx(1000 - cycle, abs=0.1)
        assert left["8000"] == pytest.approx(125 - cycle, abs=0.1)
    points = result["scale"]["points"]
    assert [p["boards"] for p in points] == [1, 2, 4]
    assert [p["bus_nodes"] for p in points] == [2, 3, 5]
    assert all(p["p50_us"] > 0 and p["count"] == 300 for p in points)
    assert result["thesis"]["quadlet"]["read"]["mean_us"] == 34.5
    assert result["machine"]["load_average_after"]
    assert "quadlet read, bands" in render(result)
    check_regime(result)
    assert elapsed < 25, f"--quick took {elapsed:.1f} s"
    # The bench's bus, supervisor and added nodes are all gone.
    assert wait_until_gone(result["target"]["bus"]) == []


def check_regime(result: dict[str, Any]) -> None:
    """Each half's switches per call: counted over every call, warm-ups included."""
    regime = result["regime"]
    # 10 rounds of 100 + 25 raw round trips; the first round warms up with 100, the rest 10.
    assert regime["raw"]["calls"] >= 10 * 125 + 100 + 9 * SWITCH_WARMUP
    assert regime["floor"]["calls"] >= 1000 + 100 + 9 * SWITCH_WARMUP
    assert regime["quadlet"]["calls"] >= 2 * (1000 + 100 + 9 * SWITCH_WARMUP)
    assert regime["block_raw"]["calls"] >= 20 * (125 + SWITCH_WARMUP)
    assert regime["block"]["calls"] >= 2 * (20 * 10 + 100 + 19 * SWITCH_WARMUP)
    for half in ("raw", "floor", "quadlet", "block_raw", "block"):
        for key in ("wakeups_per_call", "peer_wakeups_per_call", "preemptions_per_call"):
            assert 0 <= regime[half][key] < 5, (half, key, regime[half])
    assert set(regime["same_regime"]) == {"quadlet", "frame_floor", "block"}
    # The read's bare frames, timed in the quadlet rounds: as many as reads.
    floor = result["frame_floor"]
    assert floor["frames"] == 3 and floor["count"] == 1000 and floor["p50_us"] > 0
    unit = result["baseline"]["round_trip"]["p50_us"]
    assert floor["x_p50"] == pytest.approx(floor["p50_us"] / unit, abs=0.01, rel=0.01)
    read = result["quadlet"]["read"]["p50_us"]
    assert floor["read_above_p50_us"] == pytest.approx(read - floor["p50_us"], abs=0.02)
    settle_ms = result["machine"]["round_switch_settle_ms"]
    assert settle_ms == pytest.approx(settle_time(default_idle()) * 1000)
    assert "regime: idle" in render(result)


@pytest.fixture
def snake_bus() -> Iterator[LaunchedBus]:
    config = BusConfig(bus_name("bench"))
    timing = ("--heartbeat", "0.2", "--lease", "3.0")
    with LaunchedBus(config, 2, board="snake2010", node_arguments=timing) as bus:
        bus.wait_members()
        yield bus
    assert wait_until_gone(config.name) == []


@pytest.mark.process
def test_a_node_of_an_existing_bus(
    snake_bus: LaunchedBus, capsys: pytest.CaptureFixture[str]
) -> None:
    name = snake_bus.config.name
    result = bench(capsys, "--target", f"bus:{name}/1", *SMALL)
    assert result["target"] == {
        "kind": "bus",
        "bus": name,
        "node": 1,
        "board": "snake2010",
        "writes_acknowledged": True,
    }
    check_quadlets(result, 300)
    assert result["block"]["sizes"] == [1, 8, 64, 512]
    assert "growing another bus" in result["scale"]["skipped"]
    assert "skipped" in render(result)
    # The bench left the bus; the bus itself is still up.
    assert len(processes_mentioning(name)) == 3


@pytest.mark.process
def test_a_qla_board_behind_eth1394(capsys: pytest.CaptureFixture[str]) -> None:
    server = Eth1394Server(Rack([0, 3]), Endpoint("127.0.0.1", PORT))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        target = ["--target", f"udp:127.0.0.1:{PORT}", "--eth1394", "--board-id", "3"]
        result = bench(capsys, *target, *SMALL, "--skip", "scale")
    finally:
        server.stop()
        thread.join(5)
        server.close()
    assert result["target"]["kind"] == "eth1394"
    assert (result["target"]["board_id"], result["target"]["node"]) == (3, 1)
    assert result["target"]["writes_acknowledged"] is False
    assert "scale" not in result
    assert "frame_floor" not in result  # another transport: the bus's floor says nothing of it
    check_quadlets(result, 300)
    assert "not answered" in render(result)
    assert server.stats.refused == 0


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--target", "udp:127.0.0.1:11394"], "--eth1394"),
        (["--target", "udp:10.1.2.3", "--eth1394"], "loopback"),
        (["--target", "bus:default"], "bus:NAME/NODE"),
        (["--target", "bus:default/63"], "0-62"),
        (["--target", "serial:/dev/ttyS0"], "expected virtual"),
        (["--eth1394"], "goes with"),
        (["--sizes", "0-4"], "outside 1..512"),
        (["--sizes", "8"], "two sizes"),
        (["--skip", "quadlets"], "no experiment"),
        (["--board", "nonsense"], "not memory or one of"),
    ],
)
def test_user_errors(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", *argv]) == 2
    assert message in capsys.readouterr().err


def test_target_and_size_syntax() -> None:
    assert parse_target(None) == TargetSpec("virtual")
    assert parse_target("bus:lab-1/4") == TargetSpec("bus", bus="lab-1", node=4)
    assert parse_target("udp:127.0.0.2", eth1394=True).endpoint == Endpoint("127.0.0.2", 1394)
    assert size_list("1-3, 8,2", 1, 512, "--sizes") == (1, 2, 3, 8)
    with pytest.raises(CliError, match="not N or N-M"):
        size_list("a-b", 1, 512, "--sizes")
