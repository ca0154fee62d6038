"""``fw1394 wireshark-dissector``: print the Lua dissector for fw1394 traces and Eth1394."""

from __future__ import annotations

import argparse
import sys

EPILOG = """\
examples:
  fw1394 wireshark-dissector > fw1394.lua
  wireshark -X lua_script:fw1394.lua trace.pcapng
  tshark -X lua_script:fw1394.lua -r trace.pcapng -T fields -e fw1394.tcode -e fw1394.tlabel
  tshark -2 -X lua_script:fw1394.lua -r trace.pcapng -Y 'fw1394.response_time > 0.0001'
  fw1394 capture -w - | tshark -X lua_script:fw1394.lua -r - -Y fw1394.request_in
  tshark -X lua_script:fw1394.lua -r trace.pcapng -q -z expert     CRC failures, strays

The dissector is generated from fw1394's packet layouts; it registers for
fw1394's link type (LINKTYPE_USER0, 147) and for UDP port 1394 (JHU Eth1394).
Its field names are those of `fw1394 dissect -Y`. Requests link to their
responses (fw1394.response_in: needs tshark -2, so not on a pipe) and
responses to their requests (fw1394.request_in, fw1394.response_time).
"""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "wireshark-dissector",
        help="print a Wireshark Lua dissector for fw1394 traces and Eth1394",
        description="Print a Wireshark Lua dissector for fw1394 traces and Eth1394 over UDP.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from fw1394.capture.views.lua_dissector import generate

    sys.stdout.write(generate())
    return 0
