"""The protocol cores on the C core of host/c (issue #38), and the choice between them and the
Python reference cores.

`NativeRs232Core` and `NativeUsbCore` have the public interface of `Rs232Core` and `UsbCore`
(rs232_core.py, usb_core.py: the same constructor arguments and defaults, methods, counters,
`lost_reason`, `UsbCore.trace`) and the same behaviour: the protocol work (matching, hunting,
batches, timeouts, placeholders, hand-over) runs in host/c/core through the extension module
`urb.managers._native` (`make host-c-py`, which `make test-py` runs), and the completed `Transfer`
objects carry what the reference sets on them. tests/host_c/test_native_core.py drives both with
the same traces and compares everything a caller observes.

Both carry a pump (`_pump_start`, `_pump_wait`, ...: `_native_pump.c`, `_native_pump_rs232.c`), which
`USBManager` uses to run a `CharDeviceTransport`'s I/O on a C thread (usb.py) and `RS232Manager` its
serial port's (rs232.py; host/urb/README.md).

The managers build their core with `new_rs232_core()` / `new_usb_core()`, which choose:

* `URB_PURE_PYTHON` unset or empty: the C core when the extension is built from these sources
  (else the Python core; `REASON` says why);
* `URB_PURE_PYTHON=1`: the Python reference cores, whatever is built (the same variable keeps the
  pure-Python codecs of urb_msgs);
* `URB_PURE_PYTHON=0`: the C core, or ImportError saying why it cannot be used.

`URB_HOST_CORE` chooses the cores alone (the codecs still follow `URB_PURE_PYTHON`): `python` the
reference cores, `c` the C core or ImportError; unset or empty, `URB_PURE_PYTHON` decides
(bench/host_cpu.py measures the library both ways with it).

Settings the C core does not take (a timeout above one hour, say: `urb_core_config_t`'s ranges)
run on the Python core; the window and batch limits are refused with the reference's ValueError.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import Any

from urb_msgs.urb_core import USB_BATCH_MAX_BYTES, Status

from ..errors import ErrorFlag
from .base import NS_PER_MS
from .rs232_core import MAX_WINDOW, PLACEHOLDER_NS, Rs232Core, check_window
from .usb_core import UsbCore

ENV = "URB_PURE_PYTHON"
CORE_ENV = "URB_HOST_CORE"
RS232_KIND, USB_KIND = 1, 2
REPO = Path(__file__).resolve().parents[3]
FINGERPRINT_SOURCES = ("host/urb/managers/_native.c", "host/urb/managers/_native_attrs.c", "host/urb/managers/_native_xfer.c",
                       "host/urb/managers/_native_pump.c", "host/urb/managers/_native_pump_rs232.c",
                       "host/urb/managers/_native_cycle.c",
                       "host/urb/managers/_native.h",
                       "host/c/core/*.c", "host/c/core/*.h", "host/c/include/*.h", "host/c/port/handover.c",
                       "gen/c/urb_core.[ch]", "gen/c/urb_runtime.[ch]", "gen/c/urb_sensorhex.[ch]")
"""What the extension is compiled from: its FINGERPRINT is the digest of these files."""


def source_fingerprint(root: Path = REPO) -> str | None:
    """The digest of the extension's sources under `root`, or None when they are not there (an
    installed copy of the library, without the repository)."""
    files = sorted({p for pattern in FINGERPRINT_SOURCES for p in root.glob(pattern)})
    if not (root / FINGERPRINT_SOURCES[0]).exists():
        return None
    h = hashlib.sha256()
    for p in files:
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def _selection() -> tuple[Any, str]:
    """(the extension module or None, why), or ImportError when it is required and unusable."""
    setting = os.environ.get(ENV, "")
    if setting not in ("", "0", "1"):
        raise ImportError(f"urb: {ENV}={setting!r}: use 1 (Python reference cores and codecs), 0 (the C core and "
                          "codecs, or fail) or leave it unset (the C core when built)")
    cores = os.environ.get(CORE_ENV, "")
    if cores not in ("", "python", "c"):
        raise ImportError(f"urb: {CORE_ENV}={cores!r}: use python (the reference cores), c (the C core, or fail) or "
                          f"leave it unset ({ENV} decides)")
    if cores:
        setting, why_python = ("1" if cores == "python" else "0"), f"{CORE_ENV}={cores}"
    else:
        why_python = f"{ENV}=1"
    if setting == "1":
        return None, why_python
    try:
        from . import _native
    except ImportError as exc:
        why = f"the extension urb.managers._native is not built ({exc}); build it with `make host-c-py`"
    else:
        expected = source_fingerprint()
        if expected is None or _native.FINGERPRINT == expected:
            return _native, "built from these sources"
        why = (f"the extension urb.managers._native was built from other sources ({_native.FINGERPRINT}, these are "
               f"{expected}); rebuild it with `make host-c-py`")
    if setting == "0":
        raise ImportError(f"{CORE_ENV}=c or {ENV}=0 asks for the C protocol core, but {why}")
    return None, why


_NATIVE, REASON = _selection()
BACKEND = "c" if _NATIVE is not None else "python"
"""The protocol core the managers run: "c" or "python" (`REASON` says why)."""

_STATUS_OF = tuple(Status(v) for v in range(max(int(s) for s in Status) + 1))
_FLAG_OF = {int(f): f for f in ErrorFlag} | {0: ErrorFlag.NONE}


class _NoNativeCore:
    """The base of the native cores when the extension is not in use (constructing them fails)."""


_Base: Any = _NATIVE.Core if _NATIVE is not None else _NoNativeCore


def _require_native() -> None:
    if _NATIVE is None:
        raise ImportError(f"the C protocol core is not in use: {REASON}")


class NativeRs232Core(_Base, Rs232Core):  # type: ignore[misc]
    """`Rs232Core` on the C core (the same arguments, defaults and behaviour). A subclass of it
    for isinstance and typing; every public method and counter is the C core's (the base
    `_native.Core` comes first), none of the reference's state exists (its `_m` and the like)."""

    def __init__(self, *, window: int = 4, timeout_ns: int = 100 * NS_PER_MS, resync_gap_ns: int = 20 * NS_PER_MS,
                 lost_after_ns: int = 500 * NS_PER_MS, lost_after_timeouts: int = 8,
                 placeholder_ns: int = PLACEHOLDER_NS) -> None:
        _require_native()
        self.window = check_window(window)
        self.timeout_ns = timeout_ns
        self.resync_gap_ns = resync_gap_ns
        self.lost_after_ns = lost_after_ns
        self.lost_after_timeouts = lost_after_timeouts
        self.placeholder_ns = placeholder_ns
        self._setup(RS232_KIND, window, timeout_ns, lost_after_ns, lost_after_timeouts, placeholder_ns,
                    resync_gap_ns, 14, USB_BATCH_MAX_BYTES, _STATUS_OF, _FLAG_OF)

    def set_window(self, window: int) -> None:
        """Requests in flight, placeholders included (learnt from BridgeInfo.fifo_depth)."""
        self.window = check_window(window)
        self._set_window(window)


class NativeUsbCore(_Base, UsbCore):  # type: ignore[misc]
    """`UsbCore` on the C core (the same arguments, defaults and behaviour, `trace` included); a
    subclass of it as NativeRs232Core is of Rs232Core."""

    def __init__(self, *, max_batch: int = 14, window: int = MAX_WINDOW, batch_bytes: int = USB_BATCH_MAX_BYTES,
                 timeout_ns: int = 50 * NS_PER_MS, lost_after_ns: int = 500 * NS_PER_MS, lost_after_timeouts: int = 8,
                 placeholder_ns: int = PLACEHOLDER_NS) -> None:
        _require_native()
        self.window = check_window(window)
        self.max_batch = check_window(max_batch, "max_batch")
        self.batch_bytes = batch_bytes
        self.timeout_ns = timeout_ns
        self.lost_after_ns = lost_after_ns
        self.lost_after_timeouts = lost_after_timeouts
        self.placeholder_ns = placeholder_ns
        self._setup(USB_KIND, window, timeout_ns, lost_after_ns, lost_after_timeouts, placeholder_ns,
                    20 * NS_PER_MS, max_batch, batch_bytes, _STATUS_OF, _FLAG_OF)

    def set_window(self, window: int) -> None:
        """Requests in flight, placeholders included (learnt from BridgeInfo.fifo_depth)."""
        self.window = check_window(window)
        self._set_window(window)


def new_rs232_core(**settings: Any) -> Rs232Core:
    """The RS232 protocol core the managers run (`Rs232Core`'s arguments): on the C core when it
    is selected and takes the settings, else the Python reference."""
    if BACKEND == "c":
        try:
            return NativeRs232Core(**settings)
        except ValueError as exc:
            if "C core does not take" not in str(exc):
                raise
    return Rs232Core(**settings)


def new_usb_core(**settings: Any) -> UsbCore:
    """The USB protocol core the managers run (`UsbCore`'s arguments): on the C core when it is
    selected and takes the settings, else the Python reference."""
    if BACKEND == "c":
        try:
            return NativeUsbCore(**settings)
        except ValueError as exc:
            if "C core does not take" not in str(exc):
                raise
    return UsbCore(**settings)

