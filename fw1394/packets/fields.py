"""Quadlets carved into named bit fields: the building block of every layout.

1394 headers are big-endian quadlets whose bits are packed fields, and a few
logical fields (the 48-bit offset) span two quadlets. :class:`Quadlets` is a
``construct`` class that describes such a run of quadlets once, as data, and
generates from that one description

* the parser and builder it uses itself (and emits into compiled structs),
* the field table shown by ``fw1394 decode`` and the dissectors,
* the fast tuple decoder of :mod:`fw1394.packets.fast`.

A bit field is ``(name, width)`` or ``(name, width, shift)``; ``shift`` places
the bits inside a logical field that is split across quadlets, so the offset
is ``("offset", 16, 32)`` in one quadlet and ``("offset", 32)`` in the next.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import construct
from construct import Container, StreamError, stream_read, stream_write

from fw1394.errors import PacketError
from fw1394.packets.bitfields import BitField
from fw1394.packets.codegen import compile_function

FieldSpec = tuple[str, int] | tuple[str, int, int]


class Quadlets(construct.Construct):  # type: ignore[misc]
    """A fixed run of big-endian quadlets split into named bit fields."""

    def __init__(self, *quadlets: Sequence[FieldSpec]) -> None:
        super().__init__()
        self.bitfields: tuple[BitField, ...] = tuple(_place(quadlets))
        self.count = len(quadlets)
        #: Logical field names in first-appearance order.
        self.names: tuple[str, ...] = tuple(dict.fromkeys(f.name for f in self.bitfields))
        self.widths: dict[str, int] = {
            name: max(f.width + f.shift for f in self.bitfields if f.name == name)
            for name in self.names
        }
        self.format = struct.Struct(f">{self.count}I")
        namespace: dict[str, Any] = {
            "Container": Container,
            "unpack": self.format.unpack,
            "unpack_from": self.format.unpack_from,
        }
        origin = f"fw1394.packets.fields Quadlets({', '.join(self.names)})"
        self.unpack_fields: Callable[[bytes], dict[str, int]] = compile_function(
            self._parse_source("_fields", "dict"), namespace, "_fields", origin=origin
        )
        self.unpack_values: Callable[..., tuple[int, ...]] = compile_function(
            self._tuple_source("_values"), namespace, "_values", origin=origin
        )
        self.pack_fields: Callable[[Any], tuple[int, ...]] = compile_function(
            self._build_source("_quadlets"), namespace, "_quadlets", origin=origin
        )

    # -- generated code -------------------------------------------------------------
    def field_expressions(self) -> dict[str, str]:
        """Python expressions computing each logical field from ``q0``, ``q1``, ..."""
        parts: dict[str, list[str]] = {name: [] for name in self.names}
        for f in self.bitfields:
            term = f"q{f.quadlet}"
            if f.lsb:
                term = f"({term} >> {f.lsb})"
            if f.width < 32:
                term = f"({term} & {f.mask:#x})"
            if f.shift:
                term = f"({term} << {f.shift})"
            parts[f.name].append(term)
        return {name: " | ".join(terms) for name, terms in parts.items()}

    def _unpack_line(self) -> str:
        names = ", ".join(f"q{i}" for i in range(self.count))
        return f"    {names}{',' if self.count == 1 else ''} = unpack(data)\n"

    def _parse_source(self, function: str, container: str) -> str:
        items = ", ".join(f"{n}={e}" for n, e in self.field_expressions().items())
        return f"def {function}(data):\n{self._unpack_line()}    return {container}({items})\n"

    def _tuple_source(self, function: str) -> str:
        # Values in ``names`` order, read from any buffer at any offset (bulk decoding).
        items = ", ".join(self.field_expressions().values())
        unpack = self._unpack_line().replace("unpack(data)", "unpack_from(data, offset)")
        return f"def {function}(data, offset=0):\n{unpack}    return ({items},)\n"

    def quadlet_expressions(self) -> list[str]:
        """Python expressions packing each quadlet from variables named like the fields."""
        quadlets = []
        for i in range(self.count):
            terms = []
            for f in self.bitfields:
                if f.quadlet != i:
                    continue
                term = f.name if not f.shift else f"({f.name} >> {f.shift})"
                term = (
                    f"(({term} & {f.mask:#x}) << {f.lsb})" if f.lsb else f"({term} & {f.mask:#x})"
                )
                terms.append(term)
            quadlets.append(" | ".join(terms))
        return quadlets

    def _build_source(self, function: str) -> str:
        lines = [f"def {function}(obj):"]
        lines.extend(f"    {name} = obj[{name!r}]" for name in self.names)
        lines.append(f"    return ({', '.join(self.quadlet_expressions())},)")
        return "\n".join(lines) + "\n"

    def attribute_packer(self, constants: dict[str, int]) -> Callable[[Any], bytes | None]:
        """A function packing an object's attributes (``constants`` fixed) into bytes.

        It returns ``None`` when a value does not fit its field, so a caller can
        fall back to :meth:`pack`, which says which one.
        """
        lines = ["def _pack_attributes(obj):"]
        lines += self.attribute_source(constants, "obj", "header")
        lines.append("    return header")
        namespace: dict[str, Any] = {"pack": self.format.pack}
        origin = f"fw1394.packets.fields attribute packer of {', '.join(self.names)}"
        packer: Callable[[Any], bytes | None] = compile_function(
            lines, namespace, "_pack_attributes", origin=origin
        )
        return packer

    def attribute_source(self, constants: dict[str, int], source: str, target: str) -> list[str]:
        """Function-body lines packing the attributes of ``source`` into ``target``.

        The lines read each field (``constants`` fixed) into a local variable of its
        name, ``return None`` when one does not fit, and then assign the packed
        bytes to ``target``; ``pack`` must be this object's ``format.pack``. For
        generated functions that do more around the header (whole packets).
        """
        lines = []
        checks = []
        for name in self.names:
            if name in constants:
                lines.append(f"    {name} = {constants[name]!r}")
                continue
            lines.append(f"    {name} = {source}.{name}")
            checks.append(f"0 <= {name} <= {(1 << self.widths[name]) - 1:#x}")
        if checks:
            lines.append(f"    if not ({' and '.join(checks)}):")
            lines.append("        return None")
        lines.append(f"    {target} = pack({', '.join(self.quadlet_expressions())})")
        return lines

    # -- construct protocol ------------------------------------------------------------
    def _parse(self, stream: Any, context: Any, path: str) -> dict[str, int]:
        return self.unpack_fields(stream_read(stream, 4 * self.count, path))

    def pack(self, obj: Any) -> bytes:
        """The quadlets' bytes from a mapping of every field; checks each value fits."""
        try:
            quadlets = self.pack_fields(obj)
        except KeyError as missing:
            raise FieldRangeError(str(missing).strip("'"), "missing") from None
        for name in self.names:
            value = obj[name]
            if not 0 <= value < 1 << self.widths[name]:
                raise FieldRangeError(name, out_of_range(value, self.widths[name]))
        return self.format.pack(*quadlets)

    def _build(self, obj: Any, stream: Any, context: Any, path: str) -> Any:
        stream_write(stream, self.pack(obj), 4 * self.count, path)
        return obj

    def _sizeof(self, context: Any, path: str) -> int:
        return 4 * self.count

    def _emitparse(self, code: Any) -> str:
        function = f"parse_quadlets_{id(self)}"
        unpacker = f"quadlets_format_{id(self)}"
        code.append(f"{unpacker} = struct.Struct({self.format.format!r})\n")
        source = self._parse_source(function, "dict").replace("unpack(data)", "{u}")
        read = (
            f"data = io.read({4 * self.count})\n"
            f"    if len(data) != {4 * self.count}:\n"
            f"        raise StreamError('stream read less than specified amount')\n"
            f"    {{names}} = {unpacker}.unpack(data)"
        )
        names = ", ".join(f"q{i}" for i in range(self.count)) + ("," if self.count == 1 else "")
        source = source.replace("(data):", "(io):").replace(
            f"{names} = {{u}}", read.replace("{names}", names)
        )
        code.append(source)
        return f"{function}(io)"


def out_of_range(value: int, width: int) -> str:
    return f"{value} ({value:#x}) does not fit in {width} bits (0..{(1 << width) - 1:#x})"


class FieldRangeError(PacketError):
    """A value does not fit the bits its field has (``field`` names it)."""


def _place(quadlets: Sequence[Sequence[FieldSpec]]) -> Iterator[BitField]:
    for index, specs in enumerate(quadlets):
        msb = 31
        for spec in specs:
            name, width = spec[0], spec[1]
            shift = spec[2] if len(spec) == 3 else 0
            yield BitField(name, 4 * index, 4, msb, width, shift)
            msb -= width
        if msb != -1:
            raise ValueError(f"quadlet {index} of {specs!r} does not add up to 32 bits")


__all__ = ["BitField", "FieldRangeError", "FieldSpec", "Quadlets", "StreamError", "out_of_range"]
