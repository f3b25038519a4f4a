"""The cyclic pattern for the tests of the cyclic runtime (test_usb_cyclic.py, test_rs232_cyclic.py):
sleep to each 1-ms boundary, then service()."""

from __future__ import annotations

import os
import time
from collections.abc import Callable

from urb.api import URBInterface
from urb.managers.base import NS_PER_MS, BusManager


def os_threads() -> set[str]:
    """The process's threads as the kernel lists them (C threads included)."""
    return set(os.listdir("/proc/self/task"))


def tick(urb: URBInterface | BusManager, ms: int = 1) -> int:
    """`ms` ticks of the cyclic pattern: sleep to the next 1-ms boundary, service. Returns the
    callbacks run."""
    ran = 0
    for _ in range(ms):
        now = time.monotonic_ns()
        time.sleep(((now // NS_PER_MS + 1) * NS_PER_MS - now) / 1e9)
        ran += urb.service()
    return ran


def service_until(urb: URBInterface | BusManager, done: Callable[[], bool], limit_s: float = 10.0) -> None:
    """Ticks until `done()`; fails the test after `limit_s`."""
    end = time.monotonic() + limit_s
    while not done():
        assert time.monotonic() < end, "the requests did not complete while serviced"
        tick(urb)
