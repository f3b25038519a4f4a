"""The phase-1 C framing of the CAN and RS485 downlinks, loaded through ctypes.

The simulation's frames are the firmware's: identifiers from `urb_can_id`, the frames of a transfer
from the segmenter `urb_can_tx_init`/`urb_can_tx_next` (tail bytes, transfer CRC), the RS485
frames from the generated encoders and its timing (t1.5, t3.5, the turnaround allowance) from
`urb_rs485_timing`, the RS485 slave (`urb_rs485_slave.c`, with its receiver `urb_rs485_rx_*`), and the bridge's CAN
and RS485 masters and the nodes' CAN and RS485 slaves themselves (`urb_can_master.c`,
`urb_rs485_master.c`, `urb_can_slave.c`, `urb_rs485_slave.c`, behind the HALs of sim/downlink/: their
statuses, timeouts, silence rules, duplicate filter and bus-off handling are the firmware's). They are compiled from the committed sources into build/sim/liburbdl.so, a
library of its own (the full simulation library, liburbsim.so, does not link the downlink cores
yet: the node library and the bridge choose their downlink in phase 2 of issue #39).
"""

from __future__ import annotations

import ctypes
import os
import shlex
import subprocess
from dataclasses import dataclass
from functools import cache
from pathlib import Path

from ..build import BUILD, REPO, SANITIZE_FLAGS, BuildError, unpreloaded_env, variant

LIBRARY = BUILD / "liburbdl.so"
SOURCES = ["sim/downlink/sim_mailbox.c", "sim/downlink/sim_rs485_node.c", "firmware/downlink/rs485/urb_rs485_slave.c",
           "sim/downlink/sim_can_node.c", "firmware/downlink/can/urb_can_slave.c", "sim/downlink/sim_can_bridge.c", "sim/downlink/sim_rs485_bridge.c", "firmware/downlink/can/urb_can_master.c",
           "firmware/downlink/rs485/urb_rs485_master.c",
           "firmware/downlink/can/urb_can_transfer.c", "firmware/downlink/rs485/urb_rs485_frame.c",
           "gen/c/urb_runtime.c", "gen/c/urb_core.c", "gen/c/urb_can_wire.c", "gen/c/urb_rs485_wire.c"]

REQUEST, RESPONSE = 0, 1
SYNC_ID = 0x000


def library_path() -> Path:
    """build/sim/liburbdl.so, or build/sim/san/liburbdl.so when URBSIM_SANITIZE=1 selects the
    sanitized simulation (tools/sim_sanitized.py: the masters then run under ASan + UBSan too)."""
    return (BUILD / "san" / LIBRARY.name) if variant()[0] else LIBRARY


def _build() -> Path:
    library = library_path()
    inputs = ([REPO / p for p in SOURCES] + sorted((REPO / "firmware/include").glob("*.h"))
              + sorted((REPO / "gen/c").glob("*.h")) + sorted((REPO / "sim/downlink").glob("*.h")) + [Path(__file__)])
    if library.exists() and all(p.stat().st_mtime <= library.stat().st_mtime for p in inputs):
        return library
    library.parent.mkdir(parents=True, exist_ok=True)
    tmp = library.with_suffix(f".so.tmp{os.getpid()}")
    flags = ["-O1", *SANITIZE_FLAGS] if variant()[0] else ["-O2"]
    cmd = [os.environ.get("CC", "gcc"), "-std=c99", *flags, "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror",
           "-Wl,--no-undefined", f"-I{REPO / 'firmware/include'}", f"-I{REPO / 'gen/c'}",
           *(str(REPO / s) for s in SOURCES), "-o", str(tmp)]
    proc = subprocess.run(cmd, capture_output=True, text=True, env=unpreloaded_env(), check=False)
    if proc.returncode != 0:
        tmp.unlink(missing_ok=True)
        raise BuildError("building the downlink cores for the simulation failed:\n  " + shlex.join(cmd) + "\n"
                         + proc.stdout + proc.stderr + "\nFix the error above in firmware/downlink, gen/c or sim/downlink.")
    tmp.replace(library)
    return library


class _CanTx(ctypes.Structure):
    _fields_ = [("payload", ctypes.c_void_p), ("crc", ctypes.c_uint16), ("len", ctypes.c_uint8),
                ("pos", ctypes.c_uint8), ("total", ctypes.c_uint8), ("tail", ctypes.c_uint8)]


class _CanFrame(ctypes.Structure):
    _fields_ = [("id", ctypes.c_uint16), ("len", ctypes.c_uint8), ("data", ctypes.c_uint8 * 8)]


class _Timing(ctypes.Structure):
    _fields_ = [("baud", ctypes.c_uint32), ("char_us", ctypes.c_uint16), ("t15_us", ctypes.c_uint16),
                ("t35_us", ctypes.c_uint16), ("turnaround_us", ctypes.c_uint16)]


class _Select(ctypes.Structure):
    _fields_ = [("mailbox", ctypes.c_uint8), ("read", ctypes.c_bool)]


class _Request(ctypes.Structure):
    _fields_ = [("address", ctypes.c_uint8), ("select", _Select), ("data", ctypes.c_uint8 * 32),
                ("data_len", ctypes.c_uint8)]


class _Response(ctypes.Structure):
    _fields_ = [("status", ctypes.c_uint8), ("mailbox", ctypes.c_uint8), ("data", ctypes.c_uint8 * 32),
                ("data_len", ctypes.c_uint8)]


class _Sync(ctypes.Structure):
    _fields_ = [("counter", ctypes.c_uint8)]


@cache
def lib() -> ctypes.CDLL:
    """The loaded cores (built when missing or older than a source)."""
    dll = ctypes.CDLL(str(_build()))
    dll.urb_can_id.restype = ctypes.c_uint16
    dll.urb_can_id.argtypes = [ctypes.c_uint8, ctypes.c_uint8, ctypes.c_bool, ctypes.c_uint8]
    dll.urb_can_tx_init.argtypes = [ctypes.POINTER(_CanTx), ctypes.c_char_p, ctypes.c_uint8, ctypes.c_uint8]
    dll.urb_can_tx_next.restype = ctypes.c_uint8
    dll.urb_can_tx_next.argtypes = [ctypes.POINTER(_CanTx), ctypes.c_char_p]
    for name in ("urb_can_frame_bits_max", "urb_can_frame_bits_min"):
        getattr(dll, name).restype = ctypes.c_uint16
        getattr(dll, name).argtypes = [ctypes.c_uint8, ctypes.c_bool]
    dll.urb_rs485_timing.argtypes = [ctypes.POINTER(_Timing), ctypes.c_uint32]
    vp = ctypes.c_void_p
    dll.sim_can_bridge_size.restype = ctypes.c_size_t
    dll.sim_can_bridge_init.argtypes = [vp, ctypes.c_uint16]
    dll.sim_can_bridge_begin.restype = ctypes.c_bool
    dll.sim_can_bridge_begin.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint8, ctypes.c_uint8, ctypes.c_uint8,
                                         ctypes.c_uint8, ctypes.c_char_p, ctypes.c_uint32]
    dll.sim_can_bridge_poll.restype = ctypes.c_int8
    dll.sim_can_bridge_poll.argtypes = [vp, ctypes.c_uint32]
    dll.sim_can_bridge_take.restype = ctypes.c_bool
    dll.sim_can_bridge_take.argtypes = [vp, ctypes.POINTER(_CanFrame)]
    dll.sim_can_bridge_tx_done.argtypes = [vp]
    dll.sim_can_bridge_rx.argtypes = [vp, ctypes.POINTER(_CanFrame)]
    dll.sim_can_bridge_set_state.argtypes = [vp, ctypes.c_uint8]
    dll.sim_can_bridge_data.restype = ctypes.POINTER(ctypes.c_uint8)
    dll.sim_can_bridge_data.argtypes = [vp]
    dll.sim_can_bridge_recoveries.restype = ctypes.c_uint32
    dll.sim_can_bridge_recoveries.argtypes = [vp]
    dll.sim_can_bridge_aborts.restype = ctypes.c_uint32
    dll.sim_can_bridge_aborts.argtypes = [vp]
    dll.sim_rs485_bridge_size.restype = ctypes.c_size_t
    dll.sim_rs485_bridge_init.argtypes = [vp, ctypes.c_uint32, ctypes.c_uint32]
    dll.sim_rs485_bridge_begin.restype = ctypes.c_bool
    dll.sim_rs485_bridge_begin.argtypes = dll.sim_can_bridge_begin.argtypes
    dll.sim_rs485_bridge_poll.restype = ctypes.c_int8
    dll.sim_rs485_bridge_poll.argtypes = [vp, ctypes.c_uint32]
    dll.sim_rs485_bridge_tx_next.restype = ctypes.c_bool
    dll.sim_rs485_bridge_tx_next.argtypes = [vp, ctypes.POINTER(ctypes.c_uint8)]
    dll.sim_rs485_bridge_rx.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint32]
    dll.sim_rs485_bridge_next_us.restype = ctypes.c_uint32
    dll.sim_rs485_bridge_next_us.argtypes = [vp, ctypes.c_uint32]
    dll.sim_rs485_bridge_data.restype = ctypes.POINTER(ctypes.c_uint8)
    dll.sim_rs485_bridge_data.argtypes = [vp]
    dll.sim_rs485_bridge_set_silences.argtypes = [vp, ctypes.c_uint16, ctypes.c_uint16]
    dll.sim_can_node_size.restype = ctypes.c_size_t
    dll.sim_can_node_init.restype = ctypes.c_bool
    dll.sim_can_node_init.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint16]
    dll.sim_can_node_set_inbox.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint8]
    dll.sim_can_node_set_outbox.argtypes = [vp, ctypes.c_uint8, ctypes.c_char_p, ctypes.c_uint8]
    dll.sim_can_node_rx.argtypes = [vp, ctypes.POINTER(_CanFrame), ctypes.c_uint32]
    dll.sim_can_node_take.restype = ctypes.c_bool
    dll.sim_can_node_take.argtypes = [vp, ctypes.POINTER(_CanFrame)]
    dll.sim_can_node_tx_done.argtypes = [vp]
    dll.sim_can_node_set_state.argtypes = [vp, ctypes.c_uint8]
    dll.sim_can_node_inbox.restype = ctypes.POINTER(ctypes.c_uint8)
    dll.sim_can_node_inbox.argtypes = [vp, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint32)]
    dll.sim_can_node_syncs.restype = ctypes.c_uint32
    dll.sim_can_node_syncs.argtypes = [vp, ctypes.POINTER(ctypes.c_uint32)]
    dll.sim_can_node_aborts.restype = ctypes.c_uint32
    dll.sim_can_node_aborts.argtypes = [vp]
    dll.sim_rs485_node_size.restype = ctypes.c_size_t
    dll.sim_rs485_node_init.restype = ctypes.c_bool
    dll.sim_rs485_node_init.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint32, ctypes.c_uint16, ctypes.c_uint16,
                                        ctypes.c_uint32]
    dll.sim_rs485_node_set_inbox.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint8]
    dll.sim_rs485_node_set_outbox.argtypes = [vp, ctypes.c_uint8, ctypes.c_char_p, ctypes.c_uint8]
    dll.sim_rs485_node_rx.argtypes = [vp, ctypes.c_uint8, ctypes.c_uint32]
    dll.sim_rs485_node_wake_us.restype = ctypes.c_uint32
    dll.sim_rs485_node_wake_us.argtypes = [vp]
    dll.sim_rs485_node_poll.argtypes = [vp, ctypes.c_uint32]
    dll.sim_rs485_node_tx_next.restype = ctypes.c_bool
    dll.sim_rs485_node_tx_next.argtypes = [vp, ctypes.POINTER(ctypes.c_uint8)]
    dll.sim_rs485_node_inbox.restype = ctypes.POINTER(ctypes.c_uint8)
    dll.sim_rs485_node_inbox.argtypes = [vp, ctypes.c_uint8, ctypes.POINTER(ctypes.c_uint32)]
    dll.sim_rs485_node_syncs.restype = ctypes.c_uint32
    dll.sim_rs485_node_syncs.argtypes = [vp, ctypes.POINTER(ctypes.c_uint32)]
    for name, struct in (("urb_rs485_request_encode", _Request), ("urb_rs485_response_encode", _Response),
                         ("urb_rs485_sync_encode", _Sync), ("urb_can_sync_encode", _Sync)):
        fn = getattr(dll, name)
        fn.restype = ctypes.c_int32
        fn.argtypes = [ctypes.POINTER(struct), ctypes.c_char_p, ctypes.c_size_t]
    return dll


def can_id(address: int, mailbox: int, read: bool, direction: int) -> int:
    """urb_can_id: bits 0..2 mailbox, 3 read, 4..9 address, 10 the response bit."""
    return int(lib().urb_can_id(address, mailbox, read, direction))


def can_transfer(payload: bytes, tid: int) -> list[bytes]:
    """The data of each frame of a transfer, as the firmware's segmenter cuts it."""
    tx = _CanTx()
    buf = bytes(payload)
    lib().urb_can_tx_init(ctypes.byref(tx), buf, len(buf), tid)
    frames: list[bytes] = []
    out = ctypes.create_string_buffer(8)
    while True:
        n = lib().urb_can_tx_next(ctypes.byref(tx), out)
        if n == 0:
            return frames
        frames.append(out.raw[:n])


def can_sync(counter: int, tid: int) -> bytes:
    """The SYNC frame's data: CanSync (the counter) and a single-frame tail byte."""
    buf = ctypes.create_string_buffer(1)
    n = lib().urb_can_sync_encode(ctypes.byref(_Sync(counter & 0xFF)), buf, 1)
    if n != 1:
        raise ValueError(f"urb_can_sync_encode returned {n}")
    frames = can_transfer(buf.raw, tid)
    assert len(frames) == 1
    return frames[0]


def frame_bits_max(length: int) -> int:
    """urb_can_frame_bits_max (11-bit identifier)."""
    return int(lib().urb_can_frame_bits_max(length, False))


def frame_bits_min(length: int) -> int:
    """urb_can_frame_bits_min (11-bit identifier)."""
    return int(lib().urb_can_frame_bits_min(length, False))


@dataclass(frozen=True)
class Rs485Timing:
    """urb_rs485_timing's figures, in microseconds."""

    baud: int
    char_us: int
    t15_us: int
    t35_us: int
    turnaround_us: int


def rs485_timing(baud: int) -> Rs485Timing:
    t = _Timing()
    lib().urb_rs485_timing(ctypes.byref(t), baud)
    return Rs485Timing(t.baud, t.char_us, t.t15_us, t.t35_us, t.turnaround_us)


def _encoded(fn: str, msg: ctypes.Structure, capacity: int) -> bytes:
    buf = ctypes.create_string_buffer(capacity)
    n = getattr(lib(), fn)(ctypes.byref(msg), buf, capacity)
    if n < 0:
        raise ValueError(f"{fn} refused the message ({n})")
    return buf.raw[:n]


def rs485_request(address: int, mailbox: int, read: bool, data: bytes = b"") -> bytes:
    """An Rs485Request frame (generated encoder): address, MailboxSelect, data, check."""
    req = _Request(address, _Select(mailbox, read), (ctypes.c_uint8 * 32)(*data), len(data))
    return _encoded("urb_rs485_request_encode", req, 36)


def rs485_response(status: int, mailbox: int, data: bytes = b"") -> bytes:
    """An Rs485Response frame: status and mailbox, data of a read answered OK, check."""
    resp = _Response(status, mailbox, (ctypes.c_uint8 * 32)(*data), len(data))
    return _encoded("urb_rs485_response_encode", resp, 35)


def rs485_sync(counter: int) -> bytes:
    """An Rs485Sync frame (broadcast address 0, counter, check)."""
    return _encoded("urb_rs485_sync_encode", _Sync(counter & 0xFF), 3)


#: urb_dl_op_t, urb_can_state_t, URB_DOWNLINK_BUSY / _IDLE and urb_status_t's names
OP_READ, OP_WRITE, OP_SYNC = 0, 1, 2
CAN_STATE = {"error-active": 0, "error-passive": 1, "bus-off": 2}
DOWNLINK_BUSY, DOWNLINK_IDLE = -1, -2
STATUS = {0: "OK", 1: "TIMEOUT", 2: "CHECKSUM", 3: "BUSY", 4: "NO_NODE", 5: "SIZE_MISMATCH", 6: "BAD_REQUEST",
          7: "BUS_STUCK", 8: "NODE_BUSY"}


class CanBridge:
    """The firmware's CAN master (`urb_can_master.c`) behind a HAL the bus model drives."""

    def __init__(self, bitrate: int) -> None:
        self._mem = ctypes.create_string_buffer(int(lib().sim_can_bridge_size()))
        self._p = ctypes.cast(self._mem, ctypes.c_void_p)
        lib().sim_can_bridge_init(self._p, bitrate // 1000)

    def begin(self, op: int, address: int, mailbox: int, length: int, counter: int, data: bytes | None,
              now_us: int) -> bool:
        return bool(lib().sim_can_bridge_begin(self._p, op, address, mailbox, length, counter, data, now_us & 0xFFFFFFFF))

    def poll(self, now_us: int) -> int:
        """DOWNLINK_BUSY, DOWNLINK_IDLE or the final urb_status_t."""
        return int(lib().sim_can_bridge_poll(self._p, now_us & 0xFFFFFFFF))

    def take(self) -> tuple[int, bytes] | None:
        """The oldest frame the master queued: (identifier, data), or None."""
        f = _CanFrame()
        if not lib().sim_can_bridge_take(self._p, ctypes.byref(f)):
            return None
        return int(f.id), bytes(f.data[:f.len])

    def tx_done(self) -> None:
        lib().sim_can_bridge_tx_done(self._p)

    def rx(self, can_id: int, data: bytes) -> None:
        f = _CanFrame(can_id, len(data), (ctypes.c_uint8 * 8)(*data))
        lib().sim_can_bridge_rx(self._p, ctypes.byref(f))

    def set_state(self, state: str) -> None:
        lib().sim_can_bridge_set_state(self._p, CAN_STATE[state])

    def data(self, n: int) -> bytes:
        return bytes(lib().sim_can_bridge_data(self._p)[:n])

    def recoveries(self) -> int:
        """The master's recover() requests (bus-off seen at a request's begin, or a clear)."""
        return int(lib().sim_can_bridge_recoveries(self._p))

    def aborts(self) -> int:
        """The master's tx_abort() requests."""
        return int(lib().sim_can_bridge_aborts(self._p))


class Rs485Bridge:
    """The firmware's RS485 master (`urb_rs485_master.c`) behind a transceiver HAL the line drives."""

    def __init__(self, baud: int, now_us: int = 0) -> None:
        self._mem = ctypes.create_string_buffer(int(lib().sim_rs485_bridge_size()))
        self._p = ctypes.cast(self._mem, ctypes.c_void_p)
        lib().sim_rs485_bridge_init(self._p, baud, now_us)

    def set_silences(self, t15_us: int, t35_us: int) -> None:
        lib().sim_rs485_bridge_set_silences(self._p, t15_us, t35_us)

    def begin(self, op: int, address: int, mailbox: int, length: int, counter: int, data: bytes | None,
              now_us: int) -> bool:
        return bool(lib().sim_rs485_bridge_begin(self._p, op, address, mailbox, length, counter, data, now_us))

    def poll(self, now_us: int) -> int:
        """DOWNLINK_BUSY, DOWNLINK_IDLE or the final urb_status_t."""
        return int(lib().sim_rs485_bridge_poll(self._p, now_us))

    def take_all(self) -> bytes:
        """Every byte the master hands to its UART now (the request), in order."""
        out = bytearray()
        b = ctypes.c_uint8()
        while lib().sim_rs485_bridge_tx_next(self._p, ctypes.byref(b)):
            out.append(b.value)
        return bytes(out)

    def rx(self, byte: int, t_us: int) -> None:
        lib().sim_rs485_bridge_rx(self._p, byte, t_us)

    def next_us(self, now_us: int) -> int:
        """The next instant a poll may change the master's state without a byte."""
        return int(lib().sim_rs485_bridge_next_us(self._p, now_us))

    def data(self, n: int) -> bytes:
        return bytes(lib().sim_rs485_bridge_data(self._p)[:n])


class CanNode:
    """The firmware's CAN slave (`urb_can_slave.c`) of node `address`, behind a HAL the bus drives,
    with a mailbox table of fixed sizes in place of the node library (sim/downlink/sim_can_node.c)."""

    def __init__(self, address: int, bitrate: int) -> None:
        self._mem = ctypes.create_string_buffer(int(lib().sim_can_node_size()))
        self._p = ctypes.cast(self._mem, ctypes.c_void_p)
        if not lib().sim_can_node_init(self._p, address, bitrate // 1000):
            raise ValueError(f"urb_can_slave_init refused node address {address}")

    def set_inbox(self, mailbox: int, size: int) -> None:
        lib().sim_can_node_set_inbox(self._p, mailbox, size)

    def set_outbox(self, mailbox: int, data: bytes) -> None:
        lib().sim_can_node_set_outbox(self._p, mailbox, data, len(data))

    def rx(self, can_id: int, data: bytes, t_us: int) -> None:
        f = _CanFrame(can_id, len(data), (ctypes.c_uint8 * 8)(*data))
        lib().sim_can_node_rx(self._p, ctypes.byref(f), t_us & 0xFFFFFFFF)

    def take(self) -> tuple[int, bytes] | None:
        f = _CanFrame()
        if not lib().sim_can_node_take(self._p, ctypes.byref(f)):
            return None
        return int(f.id), bytes(f.data[:f.len])

    def tx_done(self) -> None:
        lib().sim_can_node_tx_done(self._p)

    def set_state(self, state: str) -> None:
        lib().sim_can_node_set_state(self._p, CAN_STATE[state])

    def inbox(self, mailbox: int, n: int) -> tuple[bytes, int]:
        """Inbox `mailbox`'s latest committed `n` bytes and the count of committed writes."""
        writes = ctypes.c_uint32()
        p = lib().sim_can_node_inbox(self._p, mailbox, ctypes.byref(writes))
        return bytes(p[:n]), int(writes.value)

    def aborts(self) -> int:
        """The slave's tx_abort() requests (an answer dropped for bus-off or a newer request)."""
        return int(lib().sim_can_node_aborts(self._p))

    def syncs(self) -> tuple[int, int]:
        """SYNCs passed on to the mailboxes and the last one's time stamp (us)."""
        last = ctypes.c_uint32()
        n = lib().sim_can_node_syncs(self._p, ctypes.byref(last))
        return int(n), int(last.value)


class Rs485Node:
    """The firmware's RS485 slave (`urb_rs485_slave.c`) of node `address`, behind a transceiver HAL
    the line drives, with the mailbox table of sim/downlink/sim_mailbox.h."""

    def __init__(self, address: int, timing: Rs485Timing, now_us: int) -> None:
        self._mem = ctypes.create_string_buffer(int(lib().sim_rs485_node_size()))
        self._p = ctypes.cast(self._mem, ctypes.c_void_p)
        if not lib().sim_rs485_node_init(self._p, address, timing.baud, timing.t15_us, timing.t35_us, now_us):
            raise ValueError(f"urb_rs485_slave_init refused node address {address}")

    def set_inbox(self, mailbox: int, size: int) -> None:
        lib().sim_rs485_node_set_inbox(self._p, mailbox, size)

    def set_outbox(self, mailbox: int, data: bytes) -> None:
        lib().sim_rs485_node_set_outbox(self._p, mailbox, data, len(data))

    def byte(self, value: int, t_us: int) -> None:
        """A byte heard on the line, stop bit at t_us."""
        lib().sim_rs485_node_rx(self._p, value, t_us)

    def wake_us(self) -> int:
        """When the slave asked to be polled (its receiver's deadline)."""
        return int(lib().sim_rs485_node_wake_us(self._p))

    def poll(self, now_us: int) -> None:
        lib().sim_rs485_node_poll(self._p, now_us)

    def take_all(self) -> bytes:
        """The answer the slave sends now (empty when it does not answer)."""
        out = bytearray()
        b = ctypes.c_uint8()
        while lib().sim_rs485_node_tx_next(self._p, ctypes.byref(b)):
            out.append(b.value)
        return bytes(out)

    def inbox(self, mailbox: int, n: int) -> tuple[bytes, int]:
        """Inbox `mailbox`'s latest committed `n` bytes and the count of committed writes."""
        writes = ctypes.c_uint32()
        p = lib().sim_rs485_node_inbox(self._p, mailbox, ctypes.byref(writes))
        return bytes(p[:n]), int(writes.value)

    def syncs(self) -> tuple[int, int]:
        """SYNCs passed on to the mailboxes and the last one's time stamp (us)."""
        last = ctypes.c_uint32()
        n = lib().sim_rs485_node_syncs(self._p, ctypes.byref(last))
        return int(n), int(last.value)
