"""From settings to a target, its reference model and its offsets.

Target specifications:

* ``inproc:BOARD``: a board emulator in this process (``fw1394.boards``
  kinds, or ``memory``);
* ``bus:NAME/NODE``: node NODE (a physical ID) of the virtual bus NAME;
* ``udp:HOST[:PORT]``: a node behind a UDP tunnel, speaking fw1394's frames or,
  with ``eth1394``, the JHU Eth1394 framing;
* ``rtl:PORTMAP[,waves=FILE]``: a link design in a Verilog simulator (``fw1394.rtl``),
  PORTMAP a port map file or the name of a shipped one (``thesis``).
"""

from __future__ import annotations

from fw1394.boards.registry import BOARDS, known_defects
from fw1394.fuzz.bustarget import BusTarget
from fw1394.fuzz.clock import SimulatedClock, WallClock
from fw1394.fuzz.contract import CONTRACTS, contract_path
from fw1394.fuzz.offsets import OffsetModel, offset_model
from fw1394.fuzz.reference import Reference
from fw1394.fuzz.settings import RTL_DEFAULTS, Settings, SettingsError, default_policy
from fw1394.fuzz.target import Target
from fw1394.fuzz.trial import Trial
from fw1394.transport.sansio.config import BusNameError, parse_bus_node

SCHEMES = ("inproc", "bus", "udp", "rtl")


def kinds() -> tuple[str, ...]:
    """Board kinds a target can be or be modelled as (the registry, read when asked)."""
    return tuple(sorted(BOARDS))


def target_kind(settings: Settings) -> str | None:
    """The board kind the target is (in-process) or is modelled as."""
    scheme, _, rest = settings.target.partition(":")
    if scheme == "inproc":
        return rest
    if scheme == "rtl" and settings.model is None:
        return _rtl_model(rest)
    return settings.model


def check(settings: Settings) -> None:
    """Raise :class:`SettingsError` for a target spec or option that cannot work."""
    scheme, colon, rest = settings.target.partition(":")
    if scheme not in SCHEMES or not colon or not rest:
        raise SettingsError(
            f"target {settings.target!r}: use inproc:BOARD, bus:NAME/NODE, udp:HOST[:PORT]"
            " or rtl:PORTMAP"
        )
    for kind in (rest if scheme == "inproc" else None, settings.model):
        if kind is not None and kind not in BOARDS:
            raise SettingsError(f"unknown board kind {kind!r}; known kinds: {', '.join(kinds())}")
    if scheme == "bus":
        bus_node(rest)
    if scheme != "rtl" and any(getattr(settings, k) != v for k, v in RTL_DEFAULTS.items()):
        raise SettingsError("--speed and --sclk-mhz are for rtl: targets")
    if scheme == "inproc":
        if settings.model not in (None, rest):
            raise SettingsError("--model must be the target's own kind in-process")
        unknown = sorted(set(settings.defects) - known_defects(rest).keys())
        if unknown:
            raise SettingsError(
                f"unknown defect {unknown[0]!r} for {rest}; see `fw1394 fuzz defects`"
            )
    elif scheme == "rtl":
        _check_rtl(settings, rest)
    elif settings.defects:
        raise SettingsError("--defect plants bugs in-process; start the node with its own --defect")
    elif settings.policy is not None:
        raise SettingsError("--policy is for in-process targets; a remote node has its own")


def open_target(settings: Settings) -> Target:
    """The target the settings name, ready to take cases."""
    check(settings)
    scheme, _, rest = settings.target.partition(":")
    if scheme == "inproc":
        from fw1394.fuzz.inproc import InprocTarget

        policy = settings.policy or default_policy(rest)
        return InprocTarget(
            rest,
            board_id=settings.board_id,
            node_id=settings.node_id,
            policy=CONTRACTS[policy],
            defects=frozenset(settings.defects),
        )
    if scheme == "bus":
        from fw1394.fuzz.bustarget import BusTarget

        name, node = bus_node(rest)
        return BusTarget.open(name, node, timeout=settings.timeout)
    if scheme == "rtl":
        from fw1394.fuzz.rtl_target import open_rtl

        try:
            return open_rtl(
                rest,
                node_id=settings.node_id,
                board_id=settings.board_id,
                defects=frozenset(settings.defects),
                speed=settings.speed,
                sclk_mhz=settings.sclk_mhz,
            )
        except ValueError as error:  # the port map, or a design that never acks
            raise SettingsError(str(error)) from None
    from fw1394.fuzz.udptarget import UdpTarget

    return UdpTarget.open(
        rest,
        node_id=settings.node_id,
        eth1394=settings.eth1394,
        timeout=settings.timeout,
        pid=settings.pid,
    )


def bus_node(spec: str) -> tuple[str, int]:
    """The bus name and physical ID of ``bus:NAME/NODE`` (``spec`` is what follows
    ``bus:``), read by the one parser of that syntax the bench uses too."""
    try:
        return parse_bus_node(spec)
    except BusNameError as error:
        raise SettingsError(str(error)) from None


def reference_for(settings: Settings, target: Target) -> Reference:
    """A fresh reference model of the target under the settings' contract."""
    return Reference(
        target_kind(settings),
        settings.board_id,
        target.node_id,
        CONTRACTS[settings.contract],
        twin=not target.restartable,
        path=contract_path(settings.contract, settings.eth1394),
        rom=target.rom_identity() if isinstance(target, BusTarget) else None,
    )


def offsets_for(settings: Settings) -> OffsetModel:
    model = offset_model(target_kind(settings), quadlet_index=settings.eth1394)
    if settings.probe_offset is None:
        return model
    return OffsetModel(model.registers, model.sweep, settings.probe_offset, model.quadlet_index)


def open_trial(settings: Settings, target: Target | None = None) -> Trial:
    """A trial on ``target`` (opened from the settings when not given)."""
    target = target or open_target(settings)
    clock = SimulatedClock(settings.seed) if target.restartable else WallClock()
    return Trial(
        target,
        reference_for(settings, target),
        offsets_for(settings),
        clock,
        probe_every=settings.probe_every,
        state_every=settings.state_every,
        history=settings.history,
    )


# -- rtl: (fw1394.rtl) ---------------------------------------------------------------------
def _rtl_model(spec: str) -> str | None:
    """The board kind a port map names (its register bus is served by that board)."""
    from fw1394.rtl.portmap import PortMapError, load, split_spec

    try:
        return load(split_spec(spec)[0]).model
    except PortMapError:
        return None


def _check_rtl(settings: Settings, spec: str) -> None:
    from fw1394.rtl.defects import known_rtl_defects
    from fw1394.rtl.portmap import PortMapError, load, split_spec

    try:
        portmap = load(split_spec(spec)[0])
    except PortMapError as error:
        raise SettingsError(str(error)) from None
    if settings.policy is not None:
        raise SettingsError("--policy is for in-process targets; the design answers its own way")
    known = known_rtl_defects(portmap)
    unknown = sorted(set(settings.defects) - known.keys())
    if unknown:
        raise SettingsError(
            f"unknown defect {unknown[0]!r} for an RTL target; known: " + ", ".join(sorted(known))
        )
