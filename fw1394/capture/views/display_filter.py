"""``dissect -Y``: a display filter over decoded fields, parsed by hand and run on columns.

The language is a small part of Wireshark's display filters, with the field
names of fw1394's Wireshark dissector (``fw1394.tcode`` or just ``tcode``)::

    expr    := or
    or      := and (("||" | "or") and)*
    and     := not (("&&" | "and") not)*
    not     := ("!" | "not") not | "(" expr ")" | test
    test    := operand [relop operand]       (a lone field: "the field is present")
             | field "in" "{" value ["," value | ".." value]... "}"
             | field ("contains" | "matches") ("\"text\"" | bytes like 00:1f:a0)
    relop   := == != < <= > >=  (or eq ne lt le gt ge)
    operand := field | integer (12, 0x1f) | value name (read_quadlet_request)
             | time: seconds as tshark writes them (0.0002), or with a unit (200us)

A field may have several values in one row (a transaction's request and
response tcodes). As in Wireshark, ``a == b`` (and ``<`` ...) holds when any
present value of ``a`` compares true, ``a != b`` when ``a`` is present and
none of its values equals ``b``; a comparison with an absent field is false.
Columns hold -1 where a field is absent, so rows are evaluated with numpy,
a whole batch at once; the text and byte fields (``kind``, ``data``) hold
Python objects, None where absent.

The field names are those the generated Lua dissector registers
(``fw1394.response_time``, ``fw1394.header_crc.status``, ``fw1394.ph.flags.partial``
...), so one filter runs in ``dissect -Y`` and in ``tshark -Y``; the short
names and the units on times are this tool's additions.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

import numpy as np

from fw1394.capture.formats import pseudo_header as ph
from fw1394.capture.formats.record import RecordType
from fw1394.errors import UsageError
from fw1394.packets import AckCode, ExtendedTCode, RCode, Retry, Speed, TCode

#: Nanoseconds per duration unit.
UNITS = {"ns": 1, "us": 1_000, "ms": 1_000_000, "s": 1_000_000_000}
PREFIX = "fw1394."


@dataclass(frozen=True)
class FieldInfo:
    """A filterable field: its canonical short name, value names, and unit."""

    name: str
    meaning: str
    enum: type[IntEnum] | None = None
    duration: bool = False  # compared with times (0.0001, 100us); values are nanoseconds
    text: str | None = None  # "string" or "bytes": compared with ==, contains, matches


_ACK_NAMES = {**{m.name: int(m) for m in AckCode}, "no_ack": 0}
FIELDS: dict[str, FieldInfo] = {
    f.name: f
    for f in (
        FieldInfo("tcode", "transaction code (a transaction: request and response)", TCode),
        FieldInfo("src", "source node ID (a transaction: the requester)"),
        FieldInfo("dst", "destination node ID (a transaction: the responder)"),
        FieldInfo("tlabel", "transaction label"),
        FieldInfo("retry", "retry code", Retry),
        FieldInfo("priority", "priority"),
        FieldInfo("offset", "48-bit destination offset"),
        FieldInfo("rcode", "response code", RCode),
        FieldInfo("data_length", "data block length (a transaction: request and response)"),
        FieldInfo("extended_tcode", "lock operation", ExtendedTCode),
        FieldInfo("quadlet_data", "quadlet payload (a transaction: request and response)"),
        FieldInfo("reserved", "reserved header bits"),
        FieldInfo("channel", "stream channel"),
        FieldInfo("tag", "stream tag"),
        FieldInfo("sy", "stream sy"),
        FieldInfo("ack", "ack code (a transaction: request and response acks)", AckCode),
        FieldInfo("ack_parity", "an ack record's parity nibble"),
        FieldInfo("generation", "bus generation"),
        FieldInfo("speed", "speed code", Speed),
        FieldInfo("record_type", "trace record kind", RecordType),
        FieldInfo("sender", "physical ID of the sending node"),
        FieldInfo("frame", "frame number (a transaction: request and response frames)"),
        FieldInfo("time", "time since the first record", duration=True),
        FieldInfo("latency", "request to response time (on a response packet)", duration=True),
        FieldInfo("attempts", "request attempts, retries included"),
        FieldInfo("request_in", "frame of the request a response answers"),
        FieldInfo("response_in", "frame of the response to a request"),
        FieldInfo("header_crc", "header CRC quadlet"),
        FieldInfo("header_crc.status", "header CRC: 0 bad, 1 good, 2 not computed"),
        FieldInfo("header_crc.valid", "header CRC matches: 1, or 0"),
        FieldInfo("data_crc", "data CRC quadlet"),
        FieldInfo("data_crc.status", "data CRC: 0 bad, 1 good, 2 not computed"),
        FieldInfo("data_crc.valid", "data CRC matches: 1, or 0"),
        FieldInfo("phy.check", "PHY packet check quadlet"),
        FieldInfo("phy.check.status", "PHY check quadlet: 0 bad, 1 good"),
        FieldInfo("phy.check.valid", "PHY check quadlet is the complement: 1, or 0"),
        FieldInfo("kind", "packet kind, as text (read_quadlet_request)", text="string"),
        FieldInfo("data", "data block bytes", text="bytes"),
        *(
            FieldInfo(f"ph.{name}", f"pseudo-header {name}")
            for name in ("version", "header_length", "ack", "observer", "reserved")
        ),
        *(FieldInfo(f"ph.flags.{name}", f"pseudo-header flag {name}") for name in ph.FLAG_NAMES),
    )
}
#: Wireshark's own names for what every frame has.
FRAME_ALIASES = {"frame.number": "frame", "frame.time_relative": "time"}
#: Other spellings, as the generated Lua dissector and the kernel name the fields.
ALIASES = {
    "src_id": "src",
    "source_id": "src",
    "dst_id": "dst",
    "destination_id": "dst",
    "length": "data_length",
    "ack_code": "ack",
    "ph.generation": "generation",
    "ph.speed": "speed",
    "ph.record_type": "record_type",
    "ph.sender": "sender",
    "response_time": "latency",
}
#: Fields that only the transaction view has.
TRANSACTION_ONLY: frozenset[str] = frozenset()
PACKET_ONLY = frozenset({"retry", "priority", "extended_tcode", "channel", "tag", "sy"})
PACKET_ONLY |= {"speed", "record_type", "sender", "kind", "data", "ack_parity", "reserved"}
PACKET_ONLY |= {name for name in FIELDS if name.startswith(("ph.", "phy.")) or "crc" in name}
#: Fields of the packet view that need every transaction of the trace paired first.
LINK_FIELDS = frozenset({"latency", "attempts", "request_in", "response_in"})


class FilterError(UsageError):
    """A bad display filter: ``position`` is the offending token's offset in the text."""

    def __init__(self, message: str, position: int, text: str) -> None:
        super().__init__(message)
        self.message = message
        self.position = position
        self.text = text

    def __str__(self) -> str:
        found = _TOKEN.match(self.text, self.position)
        token = found.group(0).strip() if found else self.text[self.position : self.position + 1]
        where = f"at {token!r} (character {self.position + 1})" if token else "at the end"
        return f"display filter {self.text!r}: {self.message} {where}"


# -- the tree ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Field:
    name: str  # canonical short name

    def text(self) -> str:
        # A field named like a value (record_type == ack) is written in full to stay a field.
        return PREFIX + self.name if self.name in _VALUE_WORDS else self.name


@dataclass(frozen=True)
class Literal:
    value: int
    spelling: str  # as written (or a canonical spelling for generated trees)

    def text(self) -> str:
        return self.spelling


Operand = Field | Literal


@dataclass(frozen=True)
class Compare:
    op: str  # one of RELOPS
    left: Operand
    right: Operand


@dataclass(frozen=True)
class Present:
    field: Field


@dataclass(frozen=True)
class Not:
    item: Node


@dataclass(frozen=True)
class And:
    items: tuple[Node, ...]


@dataclass(frozen=True)
class Or:
    items: tuple[Node, ...]


@dataclass(frozen=True)
class TextTest:
    """A text or byte field against a string, bytes or a regular expression."""

    op: str  # ==, !=, contains, matches
    field: Field
    value: str | bytes

    def pattern(self) -> re.Pattern[str]:
        assert isinstance(self.value, str)
        return re.compile(self.value)


Node = Compare | Present | Not | And | Or | TextTest
RELOPS: dict[str, Callable[[Any, Any], Any]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
_WORD_OPS = {"eq": "==", "ne": "!=", "lt": "<", "le": "<=", "gt": ">", "ge": ">="}
#: The same comparison with its operands swapped (5 < tcode is tcode > 5).
_MIRROR = {"==": "==", "!=": "!=", "<": ">", "<=": ">=", ">": "<", ">=": "<="}


def _quoted(value: str | bytes) -> str:
    if isinstance(value, bytes):
        return (
            ":".join(f"{byte:02x}" for byte in value) if len(value) > 1 else f'"\\x{value.hex()}"'
        )
    return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'


def to_text(node: Node) -> str:
    """Filter text that parses back to ``node``."""
    if isinstance(node, TextTest):
        return f"{node.field.text()} {node.op} {_quoted(node.value)}"
    if isinstance(node, Compare):
        return f"{node.left.text()} {node.op} {node.right.text()}"
    if isinstance(node, Present):
        return node.field.text()
    if isinstance(node, Not):
        inner = to_text(node.item)
        return f"!{inner}" if isinstance(node.item, Present | Not) else f"!({inner})"
    joiner = " && " if isinstance(node, And) else " || "
    return joiner.join(_wrapped(item) for item in node.items)


def _wrapped(node: Node) -> str:
    return f"({to_text(node)})" if isinstance(node, And | Or) else to_text(node)


def fields_of(node: Node) -> set[str]:
    if isinstance(node, Compare):
        return {o.name for o in (node.left, node.right) if isinstance(o, Field)}
    if isinstance(node, Present | TextTest):
        return {node.field.name}
    if isinstance(node, Not):
        return fields_of(node.item)
    return set().union(*(fields_of(item) for item in node.items))


# -- parsing -------------------------------------------------------------------------------------
_TOKEN = re.compile(
    r"""\s*(?:
        (?P<bytes>[0-9a-fA-F]{2}(?:[:.-][0-9a-fA-F]{2})+(?![0-9a-zA-Z_]))
      | (?P<number>(?:0[xX][0-9a-fA-F_]+|\d[\d_]*(?:\.\d+)?|\.\d+)(?:[a-zA-Z]+)?)
      | (?P<string>"(?:[^"\\]|\\.)*")
      | (?P<op>==|!=|<=|>=|&&|\|\||\.\.|[<>!(){},])
      | (?P<word>[A-Za-z_][A-Za-z0-9_.]*)
    )""",
    re.VERBOSE,
)


@dataclass(frozen=True)
class _Token:
    kind: str  # number, op, word, end
    text: str
    position: int


def _tokens(text: str) -> list[_Token]:
    tokens, at = [], 0
    while at < len(text):
        if text[at:].strip() == "":
            break
        match = _TOKEN.match(text, at)
        if match is None or match.lastgroup is None:
            position = at + len(text[at:]) - len(text[at:].lstrip())
            hint = " (compare with ==)" if text[position] == "=" else ""
            raise FilterError(f"unexpected character{hint}", position, text)
        kind = match.lastgroup
        value = match.group(kind)
        start = match.start(kind)
        if kind == "word" and value in _WORD_OPS:
            kind, value = "op", _WORD_OPS[value]
        elif kind == "word" and value in ("and", "or", "not"):
            kind, value = "op", {"and": "&&", "or": "||", "not": "!"}[value]
        elif kind == "word" and value in ("in", "contains", "matches"):
            kind = "op"
        tokens.append(_Token(kind, value, start))
        at = match.end()
    tokens.append(_Token("end", "", len(text)))
    return tokens


def field_name(word: str) -> str | None:
    """The canonical name of field ``word`` (``fw1394.tcode``, ``tcode``, ``src_id``...)."""
    if word in FRAME_ALIASES:
        return FRAME_ALIASES[word]
    short = word[len(PREFIX) :] if word.startswith(PREFIX) else word
    short = ALIASES.get(short, short)
    return short if short in FIELDS else None


class _Parser:
    def __init__(self, text: str) -> None:
        self.text = text
        self.tokens = _tokens(text)
        self.at = 0

    def peek(self) -> _Token:
        return self.tokens[self.at]

    def take(self) -> _Token:
        token = self.tokens[self.at]
        self.at += 1
        return token

    def error(self, message: str, token: _Token | None = None) -> FilterError:
        return FilterError(message, (token or self.peek()).position, self.text)

    def parse(self) -> Node:
        if self.peek().kind == "end":
            raise self.error("empty expression")
        node = self.or_()
        if self.peek().kind != "end":
            raise self.error("expected && or || or the end")
        return node

    def or_(self) -> Node:
        items = [self.and_()]
        while self.peek().text == "||" and self.peek().kind == "op":
            self.take()
            items.append(self.and_())
        return items[0] if len(items) == 1 else Or(tuple(items))

    def and_(self) -> Node:
        items = [self.not_()]
        while self.peek().text == "&&" and self.peek().kind == "op":
            self.take()
            items.append(self.not_())
        return items[0] if len(items) == 1 else And(tuple(items))

    def not_(self) -> Node:
        token = self.peek()
        if token.kind == "op" and token.text == "!":
            self.take()
            return Not(self.not_())
        if token.kind == "op" and token.text == "(":
            self.take()
            node = self.or_()
            if self.peek().text != ")":
                raise self.error("missing )")
            self.take()
            return node
        return self.test()

    def test(self) -> Node:
        left_token = self.peek()
        left = self.operand()
        token = self.peek()
        if token.kind == "op" and token.text in ("in", "contains", "matches"):
            if not isinstance(left, Field):
                raise self.error(f"{token.text} needs a field on its left", left_token)
            if token.text != "in" and FIELDS[left.name].text is None:
                raise self.error(
                    f"{token.text} works on text and byte fields (kind, data), not {left.name}"
                )
            self.take()
            if token.text == "in":
                return self.members(left)
            return self.text_test(token.text, left)
        if isinstance(left, Field) and FIELDS[left.name].text is not None:
            if token.kind == "op" and token.text in ("==", "!="):
                self.take()
                return self.text_test(token.text, left)
            if token.kind == "op" and token.text in RELOPS:
                raise self.error(f"{left.name} is text: compare it with ==, contains or matches")
        if token.kind == "op" and token.text in RELOPS:
            self.take()
            right_token = self.peek()
            right = self.operand()
            return _compare(token.text, left, left_token, right, right_token, self)
        if isinstance(left, Field):
            return Present(left)
        if left_token.kind == "word":
            raise self.error(_unknown_field(), left_token)
        raise self.error("a value on its own is not a test; compare it with a field", left_token)

    def members(self, field: Field) -> Node:
        """``field in {a, b, c..d}``: any of the values, or within a range."""
        if self.peek().text != "{":
            raise self.error("expected { after in")
        self.take()
        items: list[Node] = []
        if self.peek().text == "}":
            raise self.error("an empty set matches nothing; name at least one value")
        while self.peek().text != "}":
            if self.peek().kind == "end":
                raise self.error("missing }")
            low = _resolve(self.value_token(), field, self)
            if self.peek().text == "..":
                self.take()
                high = _resolve(self.value_token(), field, self)
                items.append(And((Compare(">=", field, low), Compare("<=", field, high))))
            else:
                items.append(Compare("==", field, low))
            if self.peek().text == ",":
                self.take()
        self.take()
        return items[0] if len(items) == 1 else Or(tuple(items))

    def value_token(self) -> _Token:
        token = self.take()
        if token.kind in ("number", "word"):
            return token
        self.at -= 1
        raise self.error("expected a value")

    def text_test(self, op: str, field: Field) -> TextTest:
        token = self.take()
        info = FIELDS[field.name]
        if info.text is None:
            self.at -= 1
            raise self.error(f"{op} works on text and byte fields (kind, data), not {field.name}")
        value: str | bytes
        if token.kind == "string":
            text = _unquote(token.text)
            value = text.encode("latin-1") if info.text == "bytes" and op != "matches" else text
        elif token.kind == "bytes" and info.text == "bytes" and op != "matches":
            value = bytes.fromhex(re.sub(r"[:.-]", "", token.text))
        else:
            self.at -= 1
            raise self.error('expected "text" (or bytes such as 00:1f for data)')
        if op == "matches":
            try:
                re.compile(str(value))
            except re.error as error:
                self.at -= 1
                raise self.error(f"not a regular expression ({error})") from None
        return TextTest(op, field, value)

    def operand(self) -> Field | _Pending:
        token = self.take()
        if token.kind == "word":
            name = field_name(token.text)
            if name is not None:
                return Field(name)
            return _Pending(token)
        if token.kind == "number":
            return _Pending(token)
        self.at -= 1
        if token.kind == "end":
            raise self.error("expression ends too early")
        raise self.error("expected a field or a value")


@dataclass(frozen=True)
class _Pending:
    """A value token, resolved once the field it is compared with is known."""

    token: _Token


def _compare(
    op: str,
    left: Field | _Pending,
    left_token: _Token,
    right: Field | _Pending,
    right_token: _Token,
    parser: _Parser,
) -> Compare:
    if isinstance(left, _Pending) and isinstance(right, _Pending):
        for token in (left_token, right_token):
            if token.kind == "word":
                raise parser.error(_unknown_field(), token)
        raise parser.error("compare a field, not two values", left_token)
    if isinstance(left, Field) and isinstance(right, Field):
        # A bare word that names a value of the other side's field is that value.
        if right_token.text in _value_names(left.name):
            return Compare(op, left, _resolve(right_token, left, parser))
        if left_token.text in _value_names(right.name):
            return Compare(op, _resolve(left_token, right, parser), right)
        if FIELDS[left.name].duration != FIELDS[right.name].duration:
            raise parser.error("a time cannot be compared with a number", right_token)
        return Compare(op, left, right)
    if isinstance(left, _Pending):
        assert isinstance(right, Field)
        return Compare(op, _resolve(left.token, right, parser), right)
    assert isinstance(right, _Pending)
    return Compare(op, left, _resolve(right.token, left, parser))


def _unquote(text: str) -> str:
    """A filter string's value: backslash escapes as in Wireshark (\\", \\\\, \\xNN)."""
    body = text[1:-1]
    return re.sub(
        r"\\(x[0-9a-fA-F]{2}|.)",
        lambda m: chr(int(m.group(1)[1:], 16)) if len(m.group(1)) == 3 else m.group(1),
        body,
    )


def _value_names(name: str) -> dict[str, int]:
    enum = FIELDS[name].enum
    if enum is None:
        return {}
    return _ACK_NAMES if enum is AckCode else {m.name: int(m) for m in enum}


_VALUE_WORDS = frozenset(word for name in FIELDS for word in _value_names(name))


def _unknown_field() -> str:
    return f"unknown field (known: {', '.join(FIELDS)})"


_DURATION = re.compile(r"(\d*\.?\d+)([a-zA-Z]+)")


def _resolve(token: _Token, field: Field, parser: _Parser) -> Literal:
    info = FIELDS[field.name]
    text = token.text
    if token.kind == "word":
        if info.enum is None:
            raise parser.error(f"unknown field or value (is {field.name} a number?)", token)
        names = _value_names(field.name)
        if text not in names:
            known = ", ".join(names)
            raise parser.error(f"not a {field.name} name (known: {known})", token)
        return Literal(names[text], text)
    if info.duration:
        plain = text.replace("_", "")
        match = _DURATION.fullmatch(plain)
        if match is not None and match.group(2) in UNITS:
            return Literal(round(float(match.group(1)) * UNITS[match.group(2)]), text)
        try:
            return Literal(round(float(plain) * UNITS["s"]), text)  # seconds, as tshark
        except ValueError:
            raise parser.error(
                f"{field.name} needs a time: seconds (0.0002) or with a unit (200us)", token
            ) from None
    try:
        return Literal(int(text.replace("_", ""), 0), text)
    except ValueError:
        raise parser.error(f"not an integer for {field.name} (use 12 or 0x1f)", token) from None


def parse(text: str) -> Node:
    """The tree of filter ``text``; :class:`FilterError` points at what is wrong."""
    return _Parser(text).parse()


def check_view(node: Node, text: str, view: str) -> None:
    """Refuse fields the view has no column for, before any work starts."""
    wrong = TRANSACTION_ONLY if view == "packets" else PACKET_ONLY
    for name in sorted(fields_of(node) & wrong):
        where = re.search(rf"(?<![\w.])(?:{re.escape(PREFIX)})?{re.escape(name)}\b", text)
        position = where.start() if where else 0
        other = "transaction view (--transactions)" if view == "packets" else "packet view"
        raise FilterError(f"{name} exists only in the {other}", position, text)


# -- evaluation ----------------------------------------------------------------------------------
#: Each field's values per row: one or more int64 columns, -1 where absent.
Columns = Mapping[str, tuple[np.ndarray, ...]]


def evaluate(node: Node, columns: Columns, rows: int) -> np.ndarray:
    """Which of ``rows`` rows pass, as a boolean array."""
    if isinstance(node, TextTest):
        test = _text_predicate(node)
        return np.fromiter((test(v) for v in columns[node.field.name][0]), bool, rows)
    if isinstance(node, Present):
        if FIELDS[node.field.name].text is not None:
            return np.fromiter((v is not None for v in columns[node.field.name][0]), bool, rows)
        return _any_present(columns[node.field.name], rows)
    if isinstance(node, Compare):
        return _compare_columns(node, columns, rows)
    if isinstance(node, Not):
        return ~evaluate(node.item, columns, rows)
    result = evaluate(node.items[0], columns, rows)
    for item in node.items[1:]:
        if isinstance(node, And):
            result &= evaluate(item, columns, rows)
        else:
            result |= evaluate(item, columns, rows)
    return result


def _text_predicate(node: TextTest) -> Callable[[Any], bool]:
    """Whether one row's value (None: absent) passes ``node``."""
    value = node.value
    if node.op == "matches":
        pattern = node.pattern()

        def search(v: Any) -> bool:
            if v is None:
                return False
            text = v.decode("latin-1") if isinstance(v, bytes) else v
            return pattern.search(text) is not None

        return search
    if node.op == "contains":
        return lambda v: v is not None and value in v
    if node.op == "==":
        return lambda v: v is not None and v == value
    return lambda v: v is not None and v != value


def _any_present(values: tuple[np.ndarray, ...], rows: int) -> np.ndarray:
    result = np.zeros(rows, bool)
    for column in values:
        result |= column >= 0
    return result


def _compare_columns(node: Compare, columns: Columns, rows: int) -> np.ndarray:
    op, left, right = node.op, node.left, node.right
    if isinstance(left, Literal):
        assert isinstance(right, Field)
        op, left, right = _MIRROR[op], right, left
    assert isinstance(left, Field)
    lefts = columns[left.name]
    rights: tuple[np.ndarray | int, ...]
    rights = columns[right.name] if isinstance(right, Field) else (right.value,)
    if op == "!=":
        present = np.zeros(rows, bool)
        clash = np.zeros(rows, bool)
        for a in lefts:
            for b in rights:
                both = (a >= 0) & (np.asarray(b) >= 0)
                present |= both
                clash |= both & (a == b)
        return present & ~clash
    compare = RELOPS[op]
    result = np.zeros(rows, bool)
    for a in lefts:
        for b in rights:
            result |= (a >= 0) & (np.asarray(b) >= 0) & np.asarray(compare(a, b), bool)
    return result


def evaluate_row(node: Node, values: Mapping[str, tuple[Any, ...]]) -> bool:
    """The same filter on one row, in plain Python: the reference for :func:`evaluate`."""
    if isinstance(node, TextTest):
        return _text_predicate(node)(values[node.field.name][0])
    if isinstance(node, Present):
        if FIELDS[node.field.name].text is not None:
            return values[node.field.name][0] is not None
        return any(v >= 0 for v in values[node.field.name])
    if isinstance(node, Not):
        return not evaluate_row(node.item, values)
    if isinstance(node, And):
        return all(evaluate_row(item, values) for item in node.items)
    if isinstance(node, Or):
        return any(evaluate_row(item, values) for item in node.items)

    def side(operand: Operand) -> list[int]:
        if isinstance(operand, Field):
            return [v for v in values[operand.name] if v >= 0]
        return [operand.value]

    pairs = [(a, b) for a in side(node.left) for b in side(node.right)]
    if node.op == "!=":
        return bool(pairs) and all(a != b for a, b in pairs)
    return any(bool(RELOPS[node.op](a, b)) for a, b in pairs)


class DisplayFilter:
    """A parsed ``-Y`` expression, checked against the view it filters."""

    def __init__(self, text: str, view: str) -> None:
        self.text = text
        self.tree = parse(text)
        check_view(self.tree, text, view)

    def __call__(self, columns: Columns, rows: int) -> np.ndarray:
        return evaluate(self.tree, columns, rows)

    @property
    def fields(self) -> set[str]:
        return fields_of(self.tree)


def help_lines() -> list[str]:
    """Field names and meanings, for ``dissect --help`` and errors."""
    return [f"  {name:<15} {info.meaning}" for name, info in FIELDS.items()]
