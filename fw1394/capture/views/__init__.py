"""What people see of a trace: ``fw1394 dissect``'s rows and plots, Wireshark and scapy.

The scapy layers (:mod:`~fw1394.capture.views.scapy_layers`) and the Lua
dissector (:mod:`~fw1394.capture.views.lua_dissector`) are generated from the
packet layouts; :mod:`~fw1394.capture.views.display_filter` reads tshark's
filter language. Used through ``fw1394 dissect``; no names of its own here.
"""

__all__: list[str] = []
