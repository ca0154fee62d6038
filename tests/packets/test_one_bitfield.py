"""One bit-field type places every field: quadlet layouts and flat header tables alike.

The expected places are IEEE 1394-1995 6.2.2.1 (figure 6-6, quadlet read
request): quadlet 0 is destination_ID (16 bits), tl (6), rt (2), tcode (4),
pri (4); quadlet 1 is source_ID (16) and destination_offset's top 16 bits;
quadlet 2 the offset's low 32 bits.
"""

from __future__ import annotations

import re
from pathlib import Path

import fw1394
from fw1394.capture.formats.pseudo_header import FIELDS
from fw1394.packets import TCode
from fw1394.packets.bitfields import BitField
from fw1394.packets.layouts import LAYOUTS


def test_a_quadlet_layout_is_bit_fields_at_the_specs_places() -> None:
    fields = LAYOUTS[TCode.read_quadlet_request].header.bitfields
    assert [(f.name, f.quadlet, f.msb, f.width, f.shift) for f in fields] == [
        ("destination_id", 0, 31, 16, 0),
        ("tlabel", 0, 15, 6, 0),
        ("retry", 0, 9, 2, 0),
        ("tcode", 0, 7, 4, 0),
        ("priority", 0, 3, 4, 0),
        ("source_id", 1, 31, 16, 0),
        ("offset", 1, 15, 16, 32),
        ("offset", 2, 31, 32, 0),
    ]
    assert all(type(f) is BitField and f.byte_size == 4 for f in fields)
    assert (fields[1].lsb, fields[1].mask) == (10, 0x3F)


def test_a_flat_header_table_is_the_same_type() -> None:
    assert FIELDS and all(type(f) is BitField for f in FIELDS.values())


def test_the_library_defines_one_bit_field_type() -> None:
    root = Path(fw1394.__file__).parent
    pattern = re.compile(r"^class (\w*(?:Bit|Flat)\w*Field)\b", re.MULTILINE)
    defined = [
        f"{path.relative_to(root)}:{name}"
        for path in sorted(root.rglob("*.py"))
        for name in pattern.findall(path.read_text())
    ]
    assert defined == ["packets/bitfields.py:BitField"]
