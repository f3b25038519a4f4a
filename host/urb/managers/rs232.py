"""RS232Manager: a bridge on a serial port, driven in real time (paper Sec. V-B).

Three threads, as in the paper's separate read and write paths:

* the *writer* waits for requests and writes each frame with one `write()` (so its bytes are back
  to back on the line: the bridge's idle-gap rule relies on it);
* the *reader* feeds received bytes to the core and applies timeouts every few milliseconds;
* the *dispatcher* (from `ThreadedManager`) runs callbacks in request order, so a slow callback
  delays other callbacks but never the wire.

The protocol itself is `Rs232Core` (sans-IO); this module only moves bytes and time.

On the C core (`native.NativeRs232Core`) the reader and the writer are one C thread instead (the
core's pump, `_native_pump_rs232.c`: the same reads, one write() per frame, the hand-over record
covered before the writes, the same lost reasons), which never takes the GIL and sleeps until the
port has bytes, the core's next deadline or a submission; the dispatcher wakes once per batch of
completions (`ThreadedManager._dispatch_batches`).

With `cyclic=True` no thread runs (host/urb/README.md, "The cyclic runtime"): a submission's frames
are written at once on the submitting thread (one write() per frame, as the writer does), and the
application's `service()` reads what the port received, applies the deadlines, writes the frames
a freed window lets go, and runs the callbacks on the calling thread. The I/O is in Python on
either core (300 requests per second in SensoRHex: a wake-up less per request matters more than
the C pump's speed).
"""

from __future__ import annotations

import errno
import os
import re
import select
import termios
import threading

import serial

from ..errors import PortError
from .base import NS_PER_MS, ThreadedManager
from .handover import PortHandover
from .native import new_rs232_core
from .rs232_core import PLACEHOLDER_NS

READ_POLL_S = 0.002
"""How often the reader wakes without input to apply timeouts."""

USE_PUMP = True
"""Run the port's I/O on the C core's pump when the core has one (see above); bench/host_cpu.py
--rs232-ab and the pump's tests turn it off to compare both runtimes."""


class RS232Manager(ThreadedManager):
    """A URB bridge on a serial port (a real UART, a USB serial adapter, or a pseudo-terminal)."""

    def __init__(self, port: str, baud: int = 115200, *, window: int = 4, timeout_s: float = 0.1,
                 lost_after_s: float = 0.5, placeholder_s: float = PLACEHOLDER_NS / 1e9,
                 name: str | None = None, cyclic: bool = False) -> None:
        """`port`: device path (e.g. /dev/ttyS0). `window`: requests outstanding on the bridge
        before discovery tells its FIFO depth. `timeout_s`: a request without response after
        this long completes UPLINK_TIMEOUT. `lost_after_s`: the bridge is declared lost
        (BRIDGE_LOST) only after it sent nothing for this long, with requests outstanding all
        that time or 8 requests in a row timed out (host/urb/README.md, "bridge lost"); requests
        lost in a shorter glitch just time out. `placeholder_s`: a request that timed out keeps
        its sequence number and its place in the window this long after it was sent (the bridge
        may still answer it; default 0.3 s, the firmware's worst case at 100 kb/s, see
        `rs232_core.PLACEHOLDER_NS`), unless a response releases it first; keep it below
        `lost_after_s`. `cyclic`: no thread; the application calls `service()` every tick
        (module docstring). Nothing is opened until `start`."""
        core = new_rs232_core(window=window, timeout_ns=int(timeout_s * 1e9), lost_after_ns=int(lost_after_s * 1e9),
                         placeholder_ns=int(placeholder_s * 1e9))
        super().__init__(core, name or port, cyclic=cyclic)
        self.port = port
        self.baud = baud
        self._rs = core
        self._serial: serial.Serial | None = None
        self._reader: threading.Thread | None = None
        self._writer: threading.Thread | None = None
        self._io_running = False
        self._pump_on = False
        self._wake = threading.Event()
        self._write_lock = threading.Lock()
        """A cyclic manager's frames are taken from the core and written under it, so that a
        submission on one thread and a service on another write them in the core's order."""
        self._handover = PortHandover(port)

    # -- lifecycle ------------------------------------------------------------------------------
    def start(self) -> None:
        """Open the port and start the threads; raises `PortError` saying what to do."""
        if self._serial is not None:
            return
        self._serial = open_serial(self.port, self.baud)
        self._pumped = USE_PUMP and hasattr(self._rs, "_pump_start") and not self.cyclic
        self._start_threads(self._start_io)

    def _start_io(self) -> None:
        self._io_running = True
        if self.cyclic:
            self._serviced = True
            self._send_frames()  # what was submitted before (the hand-over wait may hold it back)
            return
        if self._pumped:
            assert self._serial is not None
            record = self._handover
            self._rs._pump_start(self._serial.fileno(), self.port, 0,  # type: ignore[attr-defined]
                                 self.port if record is not None else None,
                                 str(record.path.parent) if record is not None else None)
            self._pump_on = True
            return
        self._reader = threading.Thread(target=self._read_loop, name=f"urb-read {self.port}", daemon=True)
        self._writer = threading.Thread(target=self._write_loop, name=f"urb-write {self.port}", daemon=True)
        self._reader.start()
        self._writer.start()

    def _stop_io(self) -> None:
        self._io_running = False
        self._serviced = False
        if self._pump_on:
            self._rs._pump_stop()  # type: ignore[attr-defined]
            self._pump_on = False
        self._wake.set()
        for th in (self._reader, self._writer):
            if th is not None and th is not threading.current_thread():
                th.join(timeout=2.0)
        self._reader = self._writer = None
        if self._serial is not None:
            try:
                self._serial.close()
            except (OSError, serial.SerialException):
                pass
            self._serial = None

    def close(self, *, drain: bool = True) -> None:
        """Drain (`BusManager.close`; `drain=False` skips it), stop the threads and close the
        port; outstanding requests complete BRIDGE_LOST, and so do requests submitted later
        (their callbacks then run inside `submit`)."""
        if drain:
            self._drain()
        self._stop_io()
        self._finish_close()

    def reconnect(self) -> None:
        """Reopen the port (same path: a restarted bridge, a re-plugged adapter) and reset the
        protocol. When the port cannot be opened yet, raises `PortError` and leaves the manager
        lost (`lost_reason` says why the reconnect failed; requests complete BRIDGE_LOST at
        once); call it again later."""
        self._stop_io()
        try:
            ser = open_serial(self.port, self.baud)
        except PortError as exc:
            raise self._stay_lost(str(exc), "port") from None
        self._serial = ser
        self._restart(self._start_io)

    # -- threads --------------------------------------------------------------------------------
    WAKES_IO = True

    def _wake_io(self) -> None:
        if self._serviced:
            self._send_frames()
        elif self._pump_on:
            self._rs._pump_notify()  # type: ignore[attr-defined]
        else:
            self._wake.set()

    def _lost(self, exc: BaseException) -> None:
        with self._lock:
            self._core.link_lost(self.now_ns(), f"{self.port}: {describe_io_error(exc)}")
            self._collect()
        self._io_running = False
        with self._changed:
            self._changed.notify_all()

    def _service_io(self) -> None:
        ser = self._serial
        if not self._io_running or ser is None:
            return
        if self._take_input(ser, 0.0) is not None:
            self._send_frames()

    def _send_frames(self) -> None:
        """A cyclic manager's writer: the frames the window lets go, on the calling thread."""
        ser = self._serial
        if not self._io_running or ser is None:
            return
        with self._write_lock:
            self._write_due(ser)

    def _write_due(self, ser: serial.Serial) -> bool:
        """Writes the frames the window lets go, one write() each (its bytes go back to back).
        Returns False when none was due or the port failed (the bridge is then lost)."""
        now = self.now_ns()
        with self._lock:
            frames = self._rs.frames_to_send(now)
        if not frames:
            return False
        self._note_sending(now)
        try:
            for frame in frames:
                ser.write(frame)
        except (OSError, serial.SerialException) as exc:
            self._lost(exc)
            return False
        return True

    def _take_input(self, ser: serial.Serial, wait_s: float) -> bool | None:
        """What the port received (waiting up to `wait_s` for it) to the core, then its timeouts;
        what completed goes to the dispatcher's queue. Returns whether requests wait for the
        window, or None when the port failed (the bridge is then lost)."""
        try:
            data = read_available(ser, wait_s)
        except (OSError, serial.SerialException, TypeError) as exc:
            if self._io_running:
                self._lost(exc)
            return None
        now = self.now_ns()
        with self._lock:
            if data:
                self._rs.receive(data, now)
            self._rs.poll(now)
            self._collect()
            return bool(self._rs.has_queued)

    def _write_loop(self) -> None:
        ser = self._serial
        assert ser is not None
        while self._io_running:
            self._wake.wait(READ_POLL_S * 5)
            self._wake.clear()
            while self._io_running and self._write_due(ser):
                pass

    def _read_loop(self) -> None:
        ser = self._serial
        assert ser is not None
        while self._io_running:
            more = self._take_input(ser, READ_POLL_S)
            if more is None:
                return
            if more:
                self._wake.set()


def read_available(ser: serial.Serial, wait_s: float = READ_POLL_S) -> bytes:
    """What the port has received, waiting up to `wait_s` for the first byte (b"": nothing).
    One select and one read of everything there: pyserial's `in_waiting` + `read(1)` returned
    after a response's first byte and woke the reader again for the rest (twice the wake-ups,
    ~20 % more CPU per RS232 request, bench/host_cpu.py). Raises
    `SerialException` as pyserial does when a port that reports data returns none (a USB
    adapter unplugged), `OSError` when the read fails."""
    fd = ser.fileno()
    ready, _, _ = select.select([fd], [], [], wait_s)
    if not ready:
        return b""
    try:
        data = os.read(fd, 4096)
    except BlockingIOError:  # pyserial opens the port non-blocking
        return b""
    if not data:
        raise serial.SerialException("device reports readiness to read but returned no data "
                                     "(device disconnected or multiple access on port?)")
    return data


def open_serial(port: str, baud: int) -> serial.Serial:
    """Open `port` raw 8N1 at `baud`, or raise `PortError` with what to do next."""
    try:
        ser = serial.Serial(port, baud, timeout=READ_POLL_S, write_timeout=1.0, exclusive=True)
    except serial.SerialException as exc:
        raise PortError(port_error_message(port, exc)) from None
    except (OSError, ValueError) as exc:
        raise PortError(port_error_message(port, exc)) from None
    try:
        ser.reset_input_buffer()
    except (OSError, serial.SerialException):
        pass
    return ser


def port_error_message(port: str, exc: BaseException) -> str:
    """A one-paragraph explanation of why `port` cannot be used and what to do."""
    code = error_number(exc)
    text = str(exc)
    ports = "serial ports are usually /dev/ttyS*, /dev/ttyUSB* or /dev/ttyACM* (`ls /dev/tty[SUA]*`)"
    if code == errno.ENOENT or "No such file" in text:
        return f"{port}: no such port. Check the path and the cable; {ports}."
    if code == errno.EISDIR or os.path.isdir(port):
        return f"{port}: is a directory, not a serial port. Give the bridge's device; {ports}."
    if code == errno.ENOTTY:
        kind = "a regular file" if os.path.isfile(port) else "a device that is not a terminal"
        return f"{port}: not a serial port ({kind}). Give the bridge's device; {ports}."
    if code == errno.EACCES or "Permission denied" in text:
        user = os.environ.get("USER", "$USER")
        return (f"{port}: permission denied. Add yourself to the group owning the port "
                f"(`ls -l {port}`; usually: sudo usermod -aG dialout {user}) and log in again.")
    if code == errno.EBUSY or "busy" in text.lower() or "exclusively" in text.lower():
        return f"{port}: the port is in use by another program (close it, or find it with `fuser {port}`)."
    if isinstance(exc, ValueError):
        return f"{port}: invalid serial setting ({exc}); check --baud."
    return f"{port}: cannot open the port: {describe_io_error(exc)}."


def error_number(exc: BaseException) -> int | None:
    """The errno behind an exception, wherever pyserial put it: the exception's own, its
    context's (an OSError, or termios.error's first argument), or one quoted in its text
    ("[Errno 21] ...", "(25, 'Inappropriate ioctl for device')")."""
    for candidate in (exc, exc.__context__, exc.__cause__):
        if candidate is None:
            continue
        code = getattr(candidate, "errno", None)
        if isinstance(code, int):
            return code
        args = getattr(candidate, "args", ())
        if isinstance(candidate, termios.error) and args and isinstance(args[0], int):
            return args[0]
    found = re.search(r"\[Errno (\d+)\]|\((\d+), '", str(exc))
    return int(found.group(1) or found.group(2)) if found else None


def describe_io_error(exc: BaseException) -> str:
    """What an I/O error on an open port means (the port is named by the caller)."""
    code = error_number(exc)
    if code == errno.EIO or "returned no data" in str(exc):
        return "I/O error: the device was unplugged, or the bridge process ended"
    return str(exc) or type(exc).__name__


__all__ = ["RS232Manager", "open_serial", "port_error_message", "NS_PER_MS"]
