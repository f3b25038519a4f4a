"""USBManager: a bridge on a USB uplink, driven in real time (paper Sec. V-C, Fig. 9).

A frame thread wakes on every 1-ms boundary (absolute deadlines, so wake-up jitter does not
accumulate), takes ONE batch from `UsbCore.frame_out` and hands it to the transport as one bulk-OUT
transfer. The transport pushes every bulk-IN transfer (the bridge's previous response buffer) to
the core; callbacks run on the dispatcher thread. With write n and read n-1 in flight in the same
frame, a request's callback runs at most 3 frames after its submission (UsbUplink.tla
`StrictLatency`), one more per frame it was deferred because a batch was full.

The transport is pluggable (`FrameTransport`): `CharDeviceTransport` for a kernel driver that
exposes the bridge as a character device (write = bulk-OUT, read = bulk-IN, one transfer per
call), `LoopbackFrameTransport` for tests, and the simulation's USB model (through SimManager).

On the C core (`native.NativeUsbCore`) over a `CharDeviceTransport`, the frame thread and the
transport's reader are one C thread instead (the core's pump, `_native_pump.c`: the same 1-ms
boundaries, one write per batch, one read per IN transfer, the hand-over record covered before
each write), which never takes the GIL; the dispatcher wakes once per batch of completions
(`ThreadedManager._dispatch_batches`). A core with `trace` set keeps the Python threads (the trace
records each step as it happens).

With `cyclic=True` no thread runs at all: the application calls `service()` (or
`URBInterface.service()`) once per tick, and each call reads the IN transfers that arrived, applies
the deadlines, writes ONE batch when a 1-ms boundary has passed since the last one, and runs the
callbacks on the calling thread (host/urb/README.md, "The cyclic runtime"). On the C core over a
`CharDeviceTransport` that pass is one call into C (`_pump_open`, `_pump_service`: the pump's steps
without its thread); otherwise the same steps in Python, on either core.
"""

from __future__ import annotations

import fcntl
import os
import select
import threading
import time
from collections.abc import Callable

from ..errors import PortError
from .base import ThreadedManager
from .handover import PortHandover
from .loopback import BridgeModel
from .native import new_usb_core
from .rs232_core import PLACEHOLDER_NS
from .usb_core import FRAME_NS

SERVICE_READS = 8
"""IN transfers one `service()` reads at most (as the C pump's NATIVE_SERVICE_READS), so that a
babbling device cannot hold the application's tick."""

def boundary_after(now: int) -> int:
    """The first 1-ms frame boundary after `now`."""
    return (now // FRAME_NS + 1) * FRAME_NS


def next_boundary(boundary: int, now: int) -> int:
    """The boundary after `boundary`, the one that was just served at `now`; an overslept one is
    skipped (the next after `now`), never made up in a burst."""
    boundary += FRAME_NS
    return boundary if boundary > now else boundary_after(now)


USE_PUMP = True
"""Run the uplink's I/O on the C core's pump when the core and transport allow it (see above);
bench/host_cpu.py --usb-ab turns it off to compare both runtimes under the same load."""


class USBManager(ThreadedManager):
    """A URB bridge on a USB uplink, over any `FrameTransport` (or a device path)."""

    def __init__(self, transport: object, *, max_batch: int = 14, timeout_s: float = 0.05,
                 lost_after_s: float = 0.5, placeholder_s: float = PLACEHOLDER_NS / 1e9,
                 name: str | None = None, cyclic: bool = False) -> None:
        """`transport`: a `FrameTransport`, or a device path (str) opened with
        `CharDeviceTransport`. `max_batch`: requests per 1-ms batch (at most 15 are in flight; the
        3-ms round trip holds up to 7 requests per frame, see `usb_core`).
        `timeout_s`: a response not back this long after its batch was written completes
        UPLINK_TIMEOUT. `lost_after_s` and `placeholder_s` (how long a timed-out request keeps
        its sequence number and window slot): as `RS232Manager`'s. `cyclic`: no thread; the
        application calls `service()` every tick (module docstring)."""
        core = new_usb_core(max_batch=max_batch, timeout_ns=int(timeout_s * 1e9), lost_after_ns=int(lost_after_s * 1e9),
                       placeholder_ns=int(placeholder_s * 1e9))
        if isinstance(transport, str):
            label = transport
            transport = CharDeviceTransport(transport)
        else:
            label = type(transport).__name__
        super().__init__(core, name or label, cyclic=cyclic)
        from .base import FrameTransport

        if not isinstance(transport, FrameTransport):
            raise TypeError("USBManager needs a FrameTransport (write_batch, set_batch_receiver) or a device path")
        self.transport: FrameTransport = transport
        path = getattr(transport, "path", None)
        if isinstance(path, str):
            self._handover = PortHandover(path)
        self._usb = core
        self._thread: threading.Thread | None = None
        self._io_running = False
        self._pump_on = False
        self._serviced_fd: int | None = None
        """A cyclic manager's descriptor read by `_service_io` in Python (None: the transport pushes
        its IN transfers, or the C pump reads them)."""
        self._poller: select.poll | None = None
        self._next_frame = 0

    def _reads_descriptor(self) -> bool:
        """The manager reads the transport's descriptor itself (the C pump, or a cyclic manager's
        service()): the transport is opened without its reader thread."""
        return isinstance(self.transport, CharDeviceTransport) and (self._pumped or self.cyclic)

    def _can_pump(self) -> bool:
        return (USE_PUMP and isinstance(self.transport, CharDeviceTransport) and hasattr(self._usb, "_pump_start")
                and self._usb.trace is None)

    def start(self) -> None:
        if self._thread is not None or self._pump_on or self._serviced:
            return
        self._pumped = self._can_pump()
        if isinstance(self.transport, CharDeviceTransport) and self._reads_descriptor():
            self.transport.open_descriptor()
        else:
            opener = getattr(self.transport, "open", None)
            if callable(opener):
                opener()
            self.transport.set_batch_receiver(self._on_in)
        self._start_threads(self._start_io)

    def _start_io(self) -> None:
        self._io_running = True
        if self.cyclic:
            self._open_serviced()
            return
        if self._pumped:
            assert isinstance(self.transport, CharDeviceTransport) and self.transport.fd is not None
            record = self._handover
            port = self.transport.path if record is not None else None
            self._usb._pump_start(self.transport.fd, self.name, FRAME_NS, port,  # type: ignore[attr-defined]
                                  str(record.path.parent) if record is not None else None)
            self._pump_on = True
            return
        self._thread = threading.Thread(target=self._frame_loop, name=f"urb-usb {self.name}", daemon=True)
        self._thread.start()

    def _open_serviced(self) -> None:
        """`_start_io` of a cyclic manager: the C pump opened for service, or the descriptor (when
        there is one) polled by `_service_io`."""
        record = self._handover
        port = self.transport.path if isinstance(self.transport, CharDeviceTransport) and record is not None else None
        if self._pumped:
            assert isinstance(self.transport, CharDeviceTransport) and self.transport.fd is not None
            self._usb._pump_open(self.transport.fd, self.name, FRAME_NS, port,  # type: ignore[attr-defined]
                                 str(record.path.parent) if record is not None else None)
            self._pump_on = True
        elif isinstance(self.transport, CharDeviceTransport):
            assert self.transport.fd is not None
            self._serviced_fd = self.transport.fd
            self._poller = select.poll()
            self._poller.register(self._serviced_fd, select.POLLIN)
        self._next_frame = boundary_after(time.monotonic_ns())
        self._serviced = True

    def _service_io(self) -> None:
        if self._pump_on:
            self._usb._pump_service()  # type: ignore[attr-defined]
            return
        if not self._io_running:
            return
        reads = 0
        while self._serviced_fd is not None and self._poller is not None and reads < SERVICE_READS:
            try:
                if not self._poller.poll(0):
                    break
                data = os.read(self._serviced_fd, 4096)
            except OSError:  # as CharDeviceTransport's reader: the reading ends, the next write says why
                data = b""
            if not data:
                self._serviced_fd = None
                break
            self._on_in(data)
            reads += 1
        now = self.now_ns()
        if now < self._next_frame:
            with self._lock:
                self._usb.poll(now)
            return
        self._next_frame = next_boundary(self._next_frame, now)
        self._send_frame(now)

    def _stop_io(self) -> None:
        self._io_running = False
        self._serviced = False
        self._serviced_fd = None
        self._poller = None
        if self._pump_on:
            self._usb._pump_stop()  # type: ignore[attr-defined]
            self._pump_on = False
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._thread = None

    def close(self, *, drain: bool = True) -> None:
        """Drain (`BusManager.close`; `drain=False` skips it), stop the frame thread and the
        transport (joining its reader); outstanding requests complete BRIDGE_LOST, and so do
        requests submitted later (callbacks inside `submit`)."""
        if drain:
            self._drain()
        self._stop_io()
        closer = getattr(self.transport, "close", None)
        if callable(closer):
            closer()
        self._finish_close()

    def reconnect(self) -> None:
        """Stop and join the frame thread and the transport's reader, reopen the transport,
        reset the protocol and start new threads. When the transport cannot be reopened, raises
        `PortError` and leaves the manager lost (`lost_reason` says why); call it again later."""
        self._stop_io()
        reopen = "open_descriptor" if self._reads_descriptor() else "open"
        try:
            for name in ("close", reopen):
                fn = getattr(self.transport, name, None)
                if callable(fn):
                    fn()
        except (PortError, OSError) as exc:
            text = str(exc) if isinstance(exc, PortError) else f"{self.name}: {exc}"
            raise self._stay_lost(text, "device") from None
        self._restart(self._start_io)

    def _on_in(self, data: bytes) -> None:
        with self._lock:
            self._usb.receive_batch(data, self.now_ns())
            self._collect()

    def _frame_loop(self) -> None:
        next_frame = boundary_after(time.monotonic_ns())
        while self._io_running:
            delay = next_frame - time.monotonic_ns()
            if delay > 0:
                time.sleep(delay / 1e9)
            now = self.now_ns()
            next_frame = next_boundary(next_frame, now)
            self._send_frame(now)

    def _send_frame(self, now: int) -> None:
        """One 1-ms boundary: the timeouts, then ONE batch written; a failed write loses the bridge
        and ends the I/O."""
        with self._lock:
            self._usb.poll(now)
            out = self._usb.frame_out(now)
            self._collect()
        if out is not None:
            self._note_sending(now)
            try:
                self.transport.write_batch(out)
            except OSError as exc:
                with self._lock:
                    self._core.link_lost(self.now_ns(), f"{self.name}: {exc}")
                    self._collect()
                self._io_running = False


class CharDeviceTransport:
    """A bridge behind a kernel driver's character device (or any file descriptor that keeps
    transfer boundaries, e.g. a SOCK_SEQPACKET socket): `write()` = one bulk-OUT, each `read()`
    = one bulk-IN, pushed to the receiver from a reader thread. A device opened from `path` is
    locked (`flock`) for one process at a time.

    Exactly one reader runs between `open` and `close`: `close` wakes the reader (a pipe it
    polls together with the device) and joins it before returning, so a reopened transport never
    has two threads competing for IN transfers. A descriptor passed as `fd` belongs to the
    caller and stays open; one opened from `path` is closed."""

    JOIN_S = 2.0

    def __init__(self, path: str | None = None, fd: int | None = None) -> None:
        self.path = path
        self.fd = fd
        self._receiver: Callable[[bytes], None] | None = None
        self._thread: threading.Thread | None = None
        self._stop: threading.Event | None = None
        self._wake: tuple[int, int] | None = None

    def open(self) -> None:
        """Open the device (or take the descriptor given) and start the reader thread."""
        self.open_descriptor()
        self._stop = threading.Event()
        self._wake = os.pipe()
        label = self.path if self.path is not None else f"fd {self.fd}"
        self._thread = threading.Thread(target=self._read_loop, args=(self.fd, self._stop, self._wake[0]),
                                        name=f"urb-usb-in {label}", daemon=True)
        self._thread.start()

    def open_descriptor(self) -> None:
        """Open and lock the device (`PortError` saying what to do when it cannot be), without a
        reader thread: for a manager that reads the descriptor itself (USBManager on the C core)."""
        if self._thread is not None:
            self._stop_reader()  # opened twice: still one reader
        if self.fd is None:
            assert self.path is not None
            try:
                fd = os.open(self.path, os.O_RDWR)
            except OSError as exc:
                raise PortError(f"{self.path}: cannot open the USB bridge device ({exc.strerror}); "
                                f"check the kernel driver is loaded and the device permissions") from None
            try:  # one user at a time, as pyserial's exclusive=True does for serial ports
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError:
                os.close(fd)
                raise PortError(f"{self.path}: the USB bridge is in use by another program (close it, or find "
                                f"it with `fuser {self.path}`).") from None
            self.fd = fd

    def close(self) -> None:
        self._stop_reader()
        if self.fd is not None and self.path is not None:
            os.close(self.fd)
            self.fd = None

    def _stop_reader(self) -> None:
        """Stop the reader thread and wait for it (it delivers nothing once stopped)."""
        thread, stop, wake = self._thread, self._stop, self._wake
        self._thread = self._stop = self._wake = None
        if stop is not None:
            stop.set()
        if wake is not None:
            try:
                os.write(wake[1], b"x")
            except OSError:
                pass
        if thread is not None and thread is not threading.current_thread():
            thread.join(self.JOIN_S)
        if wake is not None:
            for fd in wake:
                try:
                    os.close(fd)
                except OSError:
                    pass

    def set_batch_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver

    def write_batch(self, data: bytes) -> None:
        assert self.fd is not None
        os.write(self.fd, data)

    def _read_loop(self, fd: int, stop: threading.Event, wake: int) -> None:
        poller = select.poll()
        poller.register(fd, select.POLLIN)
        poller.register(wake, select.POLLIN)
        while not stop.is_set():
            try:
                events = poller.poll(100)  # the wake pipe ends it at once; the timeout is a backstop
            except OSError:
                return
            if stop.is_set():
                return
            if not any(efd == fd for efd, _ in events):
                continue
            try:
                data = os.read(fd, 4096)
            except OSError:
                return
            if not data:
                return
            receiver = self._receiver
            if receiver is not None and not stop.is_set():
                receiver(data)


class LoopbackUsbTransport:
    """Real-time loopback: a `BridgeModel` answering each bulk-OUT at once (the bulk-IN returns
    the bridge's previous buffer, as the hardware does)."""

    def __init__(self, bridge: BridgeModel) -> None:
        self.bridge = bridge
        self._receiver: Callable[[bytes], None] | None = None
        self._lock = threading.Lock()

    def set_batch_receiver(self, receiver: Callable[[bytes], None]) -> None:
        self._receiver = receiver

    def write_batch(self, data: bytes) -> None:
        with self._lock:
            self.bridge.usb_out(data, time.monotonic_ns())
            back = self.bridge.usb_in()
        if back is not None and self._receiver is not None:
            self._receiver(back)
