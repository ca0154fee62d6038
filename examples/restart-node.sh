#!/bin/sh
# The --restart command of `fw1394 fuzz run` and `fw1394 fuzz replay` for a node
# started by hand: stop the node whose PID is in node.pid (if it still runs),
# wait until its port is free, start a fresh one in the background and record
# its PID. Run it once by hand to start the first node.
#   FUZZ_LISTEN   address of the node (default 127.0.0.1:11395)
#   FUZZ_NODE     fw1394 fuzz serve arguments (default: a memory node with a wedge)
set -u
listen="${FUZZ_LISTEN:-127.0.0.1:11395}"
node="${FUZZ_NODE:-memory --defect wedge-after-long-block-write}"
if [ -f node.pid ]; then
    pid="$(cat node.pid)"
    kill "$pid" 2>/dev/null
    # A killed node takes a moment to let go of its port.
    for _ in 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20; do
        kill -0 "$pid" 2>/dev/null || break
        sleep 0.1
    done
fi
# shellcheck disable=SC2086  # $node is a list of arguments
fw1394 fuzz serve $node --listen "$listen" >/dev/null 2>node.log &
echo $! > node.pid
