"""The firmware's CAN and RS485 downlink code and URB nodes on those downlinks, loaded through ctypes.

The simulation's frames are the firmware's: identifiers from `urb_can_id`, the frames of a transfer
from the segmenter `urb_can_tx_init`/`urb_can_tx_next` (tail bytes, transfer CRC), the RS485
frames from the generated encoders and its timing (t1.5, t3.5, the turnaround allowance) from
`urb_rs485_timing`. The bridge's CAN and RS485 masters (`urb_can_master.c`, `urb_rs485_master.c`)
run behind the HALs of sim/downlink/ (sim_can_bridge.c, sim_rs485_bridge.c), and every node is a
real URB node (sim/downlink/sim_dl_node.c): the node library (firmware/node, its downlink adapter
urb_node_dl.c with urb_node_can.c or urb_node_rs485.c, and the slaves `urb_can_slave.c`,
`urb_rs485_slave.c`) running a SensoRHex application (firmware/apps/sensorhex) or the simulation's
probe (firmware/hal/sim/sim_apps.c). Statuses, timeouts, silence rules, duplicate filter, bus-off
handling, mailbox sizes and contents, SYNC hand-over and the heartbeat PLL are the firmware's.

Everything comes from the simulation library, build/sim/liburbsim.so (urb_sim.build), so these nodes
run the very objects the I2C world's nodes run; URBSIM_SANITIZE=1 and URBSIM_MUTANT=NAME select its
sanitized or seeded-bug build as for every other experiment.
"""

from __future__ import annotations

import ctypes
from dataclasses import dataclass
from functools import cache

from ..build import check_loadable, ensure_library

REQUEST, RESPONSE = 0, 1
SYNC_ID = 0x000


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
    """The loaded simulation library (built when missing or older than a source)."""
    check_loadable()
    dll = ctypes.CDLL(str(ensure_library()))
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
    u8, u16, u32 = ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32
    p_u32 = ctypes.POINTER(ctypes.c_uint32)
    node_sigs: dict[str, tuple[object, list[object]]] = {
        "sim_dl_node_size": (ctypes.c_size_t, []),
        "sim_dl_node_init": (ctypes.c_int, [vp, u8, u8, u8, u8, u16, u32]),
        "sim_dl_node_run": (None, [vp, u32]),
        "sim_dl_node_attach_can": (ctypes.c_bool, [vp, u16]),
        "sim_dl_node_can_rx": (None, [vp, ctypes.POINTER(_CanFrame), u32]),
        "sim_dl_node_can_take": (ctypes.c_bool, [vp, ctypes.POINTER(_CanFrame)]),
        "sim_dl_node_can_tx_done": (None, [vp]),
        "sim_dl_node_can_set_state": (None, [vp, u8]),
        "sim_dl_node_can_aborts": (u32, [vp]),
        "sim_dl_node_attach_rs485": (ctypes.c_bool, [vp, u32, u16, u16, u32]),
        "sim_dl_node_rs485_rx": (None, [vp, u8, u32]),
        "sim_dl_node_rs485_wake_us": (u32, [vp]),
        "sim_dl_node_rs485_poll": (None, [vp, u32]),
        "sim_dl_node_rs485_tx_next": (ctypes.c_bool, [vp, ctypes.POINTER(ctypes.c_uint8)]),
        "sim_dl_node_last_read": (ctypes.POINTER(ctypes.c_uint8), [vp, u8, p_u32]),
        "sim_dl_node_last_commit": (ctypes.POINTER(ctypes.c_uint8), [vp, u8, p_u32]),
        "sim_dl_node_syncs": (u32, [vp, p_u32]),
        "sim_dl_node_beats": (u32, [vp]),
        "sim_dl_node_sync_state": (u8, [vp]),
        "sim_dl_node_hooks": (vp, [vp]),
        "sim_dl_node_motor_sample": (None, [vp, u16, ctypes.c_int16, ctypes.c_int16]),
        "sim_dl_node_motor_drive": (u32, [vp, ctypes.POINTER(ctypes.c_int16), ctypes.POINTER(ctypes.c_bool), p_u32]),
    }
    for name, (restype, argtypes) in node_sigs.items():
        fn = getattr(dll, name)
        fn.restype = restype
        fn.argtypes = argtypes
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


#: the applications a node may run (firmware/hal/sim/sim_devices.h SIM_APP_*)
APPS = {"probe": 0, "motor": 1, "battery": 2, "imu": 3, "ir": 4}
#: urb_node_sync_t
SYNC_STATE = {0: "off", 1: "free", 2: "track", 3: "locked"}


@dataclass(frozen=True)
class App:
    """What a node runs: a SensoRHex application (motor, battery, imu, ir) or the simulation's probe
    with `out_size` bytes in outbox 1 and `in_size` in inbox 1 (0: none); `heartbeat_us` replaces the
    node's nominal heartbeat (the SYNC period) unless 0."""

    name: str
    out_size: int = 0
    in_size: int = 0
    heartbeat_us: int = 0

    def __post_init__(self) -> None:
        if self.name not in APPS:
            raise ValueError(f"no node application {self.name!r}: use one of {', '.join(APPS)}")


class DlNode:
    """A URB node (sim/downlink/sim_dl_node.c): the node library and its application, started at
    `now_us`. Subclasses put it on a bus."""

    def __init__(self, address: int, app: App, now_us: int) -> None:
        self.address, self.app = address, app
        self._mem = ctypes.create_string_buffer(int(lib().sim_dl_node_size()))
        self._p = ctypes.cast(self._mem, ctypes.c_void_p)
        rc = lib().sim_dl_node_init(self._p, APPS[app.name], address, app.out_size, app.in_size, app.heartbeat_us,
                                    now_us & 0xFFFFFFFF)
        if rc != 0:
            raise ValueError(f"urb_node_init refused node {address} running {app} ({rc}): check the sizes "
                             "(a probe's outbox 1..32 bytes, its inbox 0..32)")

    def run(self, now_us: int) -> None:
        """Runs the node (heartbeats, main loop) up to now_us."""
        lib().sim_dl_node_run(self._p, now_us & 0xFFFFFFFF)

    def last_read(self, mailbox: int, n: int) -> tuple[bytes, int]:
        """The first `n` bytes of the outbox buffer the last read of `mailbox` latched, and the reads so far."""
        count = ctypes.c_uint32()
        p = lib().sim_dl_node_last_read(self._p, mailbox, ctypes.byref(count))
        return bytes(p[:n]), int(count.value)

    def inbox(self, mailbox: int, n: int) -> tuple[bytes, int]:
        """Inbox `mailbox`'s first `n` bytes as the application's next lock sees them after the last
        committed write, and the committed writes so far."""
        count = ctypes.c_uint32()
        p = lib().sim_dl_node_last_commit(self._p, mailbox, ctypes.byref(count))
        return bytes(p[:n]), int(count.value)

    def syncs(self) -> tuple[int, int]:
        """SYNCs the node library time-stamped and the last one's stamp (us)."""
        last = ctypes.c_uint32()
        n = lib().sim_dl_node_syncs(self._p, ctypes.byref(last))
        return int(n), int(last.value)

    def beats(self) -> int:
        return int(lib().sim_dl_node_beats(self._p))

    def sync_state(self) -> str:
        """The heartbeat PLL's state: off, free, track or locked."""
        return SYNC_STATE[int(lib().sim_dl_node_sync_state(self._p))]

    def hooks(self) -> int:
        """The address of the urb_node_hooks_t the node library calls (the application's object)."""
        return int(lib().sim_dl_node_hooks(self._p) or 0)

    def motor_sample(self, encoder: int, current_ma: int = 0, voltage_mv: int = 0) -> None:
        """The motor's encoder, current and voltage that the next update acquires."""
        lib().sim_dl_node_motor_sample(self._p, encoder & 0xFFFF, current_ma, voltage_mv)

    def motor_drive(self) -> tuple[int, int, bool, int]:
        """(drives so far, the last one's mV, whether its update took a new command, when in us)."""
        mv, fresh, t = ctypes.c_int16(), ctypes.c_bool(), ctypes.c_uint32()
        n = lib().sim_dl_node_motor_drive(self._p, ctypes.byref(mv), ctypes.byref(fresh), ctypes.byref(t))
        return int(n), int(mv.value), bool(fresh.value), int(t.value)


class CanNode(DlNode):
    """A node on a CAN bus at `bitrate` (urb_node_can_attach), behind a controller the bus drives."""

    def __init__(self, address: int, bitrate: int, app: App, now_us: int = 0) -> None:
        super().__init__(address, app, now_us)
        if not lib().sim_dl_node_attach_can(self._p, bitrate // 1000):
            raise ValueError(f"urb_can_slave_init refused node address {address} (CAN addresses are 1..63)")

    def rx(self, can_id: int, data: bytes, t_us: int) -> None:
        f = _CanFrame(can_id, len(data), (ctypes.c_uint8 * 8)(*data))
        lib().sim_dl_node_can_rx(self._p, ctypes.byref(f), t_us & 0xFFFFFFFF)

    def take(self) -> tuple[int, bytes] | None:
        f = _CanFrame()
        if not lib().sim_dl_node_can_take(self._p, ctypes.byref(f)):
            return None
        return int(f.id), bytes(f.data[:f.len])

    def tx_done(self) -> None:
        lib().sim_dl_node_can_tx_done(self._p)

    def set_state(self, state: str) -> None:
        lib().sim_dl_node_can_set_state(self._p, CAN_STATE[state])

    def aborts(self) -> int:
        """The slave's tx_abort() requests (an answer dropped for bus-off or a newer request)."""
        return int(lib().sim_dl_node_can_aborts(self._p))


class Rs485Node(DlNode):
    """A node on an RS485 line (urb_node_rs485_attach) with `timing`, behind a transceiver the line drives."""

    def __init__(self, address: int, timing: Rs485Timing, now_us: int, app: App) -> None:
        super().__init__(address, app, now_us)
        if not lib().sim_dl_node_attach_rs485(self._p, timing.baud, timing.t15_us, timing.t35_us, now_us):
            raise ValueError(f"urb_rs485_slave_init refused node address {address} (RS485 addresses are 1..127)")

    def byte(self, value: int, t_us: int) -> None:
        """A byte heard on the line, stop bit at t_us."""
        lib().sim_dl_node_rs485_rx(self._p, value, t_us)

    def wake_us(self) -> int:
        """When the slave asked to be polled (its receiver's deadline)."""
        return int(lib().sim_dl_node_rs485_wake_us(self._p))

    def poll(self, now_us: int) -> None:
        lib().sim_dl_node_rs485_poll(self._p, now_us)

    def take_all(self) -> bytes:
        """The answer the slave sends now (empty when it does not answer)."""
        out = bytearray()
        b = ctypes.c_uint8()
        while lib().sim_dl_node_rs485_tx_next(self._p, ctypes.byref(b)):
            out.append(b.value)
        return bytes(out)
