"""Dying with the parent: the kernel ends a node when the process that started it goes."""

from __future__ import annotations

import os
import signal
import subprocess
import sys

import pytest
from polling import wait_until

from fw1394.transport.supervision.procs import process_alive

# The middle process starts a child that asks to die with it, prints the child's
# pid, then waits to be killed; SIGKILL leaves it no chance to end the child itself.
# The child says when it has asked (a child whose parent is gone before it asks
# ends itself at once, which would pass this test for the wrong reason).
MIDDLE = """
import subprocess, sys, time
child = subprocess.Popen([sys.executable, "-c", sys.argv[1], str(__import__("os").getpid())])
print(child.pid, flush=True)
time.sleep(60)
"""
CHILD = """
import os, sys, time
from fw1394.transport.supervision.procs import die_with_parent
die_with_parent(int(sys.argv[1]))
print("asked", flush=True)
time.sleep(60)
"""


@pytest.mark.process
def test_a_child_that_asked_dies_when_its_parent_is_killed() -> None:
    middle = subprocess.Popen(
        [sys.executable, "-c", MIDDLE, CHILD], stdout=subprocess.PIPE, text=True
    )
    try:
        assert middle.stdout is not None
        child = int(middle.stdout.readline())
        assert middle.stdout.readline() == "asked\n"
        assert process_alive(child)
        os.kill(middle.pid, signal.SIGKILL)
        middle.wait(10)
        assert wait_until(lambda: not process_alive(child), timeout=10)
    finally:
        middle.kill()
        middle.wait()
