"""ctypes bindings of build/sim/liburbsim.so (sim/world/urbsim.h), with Python types.

`World` owns one simulated system. Everything here is a thin, typed wrapper: the behaviour is
documented in sim/world/urbsim.h and sim/README.md.
"""

from __future__ import annotations

import ctypes
import math
from ctypes import POINTER, c_char_p, c_double, c_int, c_int32, c_int64, c_uint8, c_uint32, c_uint64, c_void_p
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path
from typing import Any

from .build import check_loadable, ensure_library

RS232 = 0
USB = 1
UPLINK_NAMES = {RS232: "RS232", USB: "USB"}
MAX_BRIDGES = 8    #: sim/world/world.c MAX_BRIDGES
MAX_NODES = 128    #: sim/world/world.c MAX_NODES
MAX_NATIVE_REQUESTS = 32  #: sim/world/native_host.h NH_MAX_REQS


class App(IntEnum):
    """Node applications (sim/world/urbsim.h URBSIM_APP_*)."""

    PROBE = 0
    MOTOR = 1
    BATTERY = 2
    IMU = 3
    IR = 4


class Mark(IntEnum):
    """Kinds in the device mark logs."""

    BEAT = 0
    ACQ_END = 1
    SYNC = 2
    READ = 3
    BOOT = 4
    DRIVE = 5
    SERVE = 8
    BRIDGE_SYNC = 9
    EMIT = 10


class Trace(IntEnum):
    """Trace categories (sim/core/trace.h)."""

    BUS = 1
    FRAME = 2
    BRIDGE = 4
    MAILBOX = 8
    FAULT = 16
    SYNC = 32
    HOST = 64
    ALL = 127


_lib: Any = None


def lib() -> Any:
    """The loaded library (built first when stale)."""
    global _lib
    if _lib is None:
        check_loadable()
        path = ensure_library()
        dll = ctypes.CDLL(str(path))
        W = c_void_p
        sigs: dict[str, tuple[Any, list[Any]]] = {
            "urbsim_new": (W, [c_uint64]),
            "urbsim_free": (None, [W]),
            "urbsim_set": (c_int, [W, c_char_p, c_double]),
            "urbsim_get": (c_double, [W, c_char_p]),
            "urbsim_param_count": (c_int, []),
            "urbsim_param_name": (c_char_p, [c_int]),
            "urbsim_param_default": (c_double, [c_int]),
            "urbsim_param_doc": (c_char_p, [c_int]),
            "urbsim_add_bridge": (c_int, [W, c_int]),
            "urbsim_add_node": (c_int, [W, c_int, c_int, c_int, c_int]),
            "urbsim_trace_open": (c_int, [W, c_char_p, c_uint32]),
            "urbsim_start": (c_int, [W]),
            "urbsim_run": (c_int, [W, c_uint64]),
            "urbsim_now": (c_uint64, [W]),
            "urbsim_events": (c_uint64, [W]),
            "urbsim_trace_hash": (c_uint64, [W]),
            "urbsim_trace_lines": (c_uint64, [W]),
            "urbsim_trace_flush": (None, [W]),
            "urbsim_host_local": (c_int64, [W]),
            "urbsim_host_timer": (c_uint64, [W, c_int64]),
            "urbsim_host_send": (c_int, [W, c_int, POINTER(c_uint8), c_uint32]),
            "urbsim_host_take": (c_int, [W, POINTER(c_int), POINTER(c_uint8), c_uint32]),
            "urbsim_host_take_more": (c_int, [W, POINTER(c_int), POINTER(c_uint32), POINTER(c_uint8), c_uint32]),
            "urbsim_run_take": (c_int, [W, c_uint64, POINTER(c_int), POINTER(c_uint32), POINTER(c_uint8), c_uint32]),
            "urbsim_node_marks": (c_uint32, [W, c_int, POINTER(c_uint64), POINTER(c_uint32), c_uint32]),
            "urbsim_bridge_marks": (c_uint32, [W, c_int, POINTER(c_uint64), POINTER(c_uint32), c_uint32]),
            "urbsim_node_status": (c_int, [W, c_int, POINTER(c_int64)]),
            "urbsim_stat": (c_double, [W, c_char_p, c_int]),
            "urbsim_node_plant": (c_int, [W, c_int, POINTER(c_double)]),
            "urbsim_native_host": (c_int, [W, c_int, c_int]),
            "urbsim_native_request": (c_int, [W, c_int, c_int, c_int, c_int, c_int, c_int]),
            "urbsim_native_stat": (c_double, [W, c_int, c_char_p]),
            "urbsim_fault_i2c_ber": (c_int, [W, c_int, c_double]),
            "urbsim_fault_i2c_stuck": (c_int, [W, c_int, c_int, c_uint64, c_uint32]),
            "urbsim_fault_uart": (c_int, [W, c_int, c_int, c_double, c_double]),
            "urbsim_fault_usb_loss": (c_int, [W, c_int, c_double]),
            "urbsim_node_power": (c_int, [W, c_int, c_int]),
            "urbsim_bridge_power": (c_int, [W, c_int, c_int]),
            "urbsim_fault_babble": (c_int, [W, c_int, c_int, c_double]),
            # the C host library on the simulated CPU (sim/world/sim_host_c.h; urb_sim.chost)
            "urbsim_chost_new": (c_void_p, [W]),
            "urbsim_chost_free": (None, [c_void_p]),
            "urbsim_chost_bridge": (c_int, [c_void_p, c_int, c_int, c_int, c_int, c_int]),
            "urbsim_chost_pending": (c_int, [c_void_p, c_int, c_int, c_int64, c_uint64]),
            "urbsim_chost_axis": (c_int, [c_void_p, c_int, c_int, c_int, c_double, c_double, c_double, c_double,
                                          c_double, c_int]),
            "urbsim_chost_log": (c_int, [c_void_p, c_int, c_uint32, POINTER(c_double), c_uint32]),
            "urbsim_chost_read": (c_int, [c_void_p, c_int, c_int, c_int, c_int, c_int]),
            "urbsim_chost_write": (c_int, [c_void_p, c_int, c_int, c_int, c_char_p, c_int, c_int]),
            "urbsim_chost_submit": (c_int, [c_void_p, c_int, c_int, c_int, c_char_p, c_int]),
            "urbsim_chost_loop": (c_int, [c_void_p, c_int64, c_uint32, c_int64]),
            "urbsim_chost_advance_to": (c_int, [c_void_p, c_uint64]),
            "urbsim_chost_samples": (c_int, [c_void_p, c_int, c_uint32, POINTER(c_int64), POINTER(c_double),
                                             POINTER(c_double), c_uint32]),
            "urbsim_chost_commands": (c_int, [c_void_p, c_int, c_uint32, POINTER(c_int32), c_uint32]),
            "urbsim_chost_requests": (c_int, [c_void_p, c_uint32, POINTER(c_uint32), POINTER(c_int64),
                                              POINTER(c_int64), POINTER(c_uint32), c_uint32]),
            "urbsim_chost_stat": (c_double, [c_void_p, c_char_p]),
        }
        for name, (res, args) in sigs.items():
            fn = getattr(dll, name)
            fn.restype = res
            fn.argtypes = args
        _lib = dll
    return _lib


@dataclass(frozen=True)
class Param:
    """One simulation parameter: name, default and meaning (sim/world/params.h)."""

    name: str
    default: float
    doc: str


def params() -> list[Param]:
    """The full parameter table, in declaration order."""
    L = lib()
    return [Param(L.urbsim_param_name(i).decode(), float(L.urbsim_param_default(i)), L.urbsim_param_doc(i).decode())
            for i in range(L.urbsim_param_count())]


@dataclass
class NodeStatus:
    """A node's heartbeat state (urb_node_sync_status)."""

    state: int
    period_q8: int
    phase_q8: int
    lead_ticks: int
    acq_ticks: int
    syncs: int
    rejected: int
    synced: bool
    init_result: int


class World:
    """One simulated URB system. Build (set, add_bridge, add_node), start, then run.

    Every misuse raises before the C world is touched, with the reason: ValueError for a bad
    argument (unknown bridge or node, address taken, probability outside [0, 1], ...),
    RuntimeError for a call in the wrong phase (building after start, running before it, anything
    after close)."""

    def __init__(self, seed: int) -> None:
        self._w: Any = None
        self._lib = lib()
        self._w = self._lib.urbsim_new(seed & 0xFFFFFFFFFFFFFFFF)
        if not self._w:
            raise MemoryError("urbsim_new failed")
        self.seed = seed
        self._buf = (c_uint8 * 1024)()
        # run_take's and take_more's out-arguments, made once: they run at every host wake-up
        self._taken_bridge = c_int(0)
        self._taken_more = c_uint32(0)
        self._taken_args = (ctypes.byref(self._taken_bridge), ctypes.byref(self._taken_more), self._buf,
                            len(self._buf))
        # Virtual time and the host clock only move in run() (and start()); the host library asks
        # for the clock ~60 times per simulated ms, so both are read once per instant, not per call.
        self._now: int | None = None
        self._local: int | None = None
        self._marks_t = (c_uint64 * 8192)()
        self._marks_v = (c_uint32 * 8192)()
        self._started = False
        self._uplinks: list[int] = []                    # per bridge
        self._nodes: list[tuple[int, int]] = []          # per node: (bridge, address)
        self._native: dict[int, int] = {}                # native bridge -> requests added
        from .profiles import active_params

        for name, value in active_params().items():  # the hardware profile applied in this process
            self.set(name, value)

    def close(self) -> None:
        """Free the C world; every later call but close() raises RuntimeError."""
        if self._w:
            self._lib.urbsim_free(self._w)
            self._w = None
        self._now = self._local = None

    def __del__(self) -> None:
        if getattr(self, "_w", None):
            self.close()

    # -- construction -----------------------------------------------------------------------
    def set(self, name: str, value: float) -> None:
        self._building("set")
        if self._lib.urbsim_set(self._w, name.encode(), float(value)) != 0:
            known = ", ".join(p.name for p in params())
            raise KeyError(f"unknown simulation parameter {name!r}; known: {known}")

    def get(self, name: str) -> float:
        self._open()
        v = float(self._lib.urbsim_get(self._w, name.encode()))
        if math.isnan(v):
            raise KeyError(f"unknown simulation parameter {name!r}")
        return v

    def add_bridge(self, uplink: int) -> int:
        """Add a bridge with uplink RS232 or USB; returns its number (0, 1, ...)."""
        self._building("add_bridge")
        if uplink not in UPLINK_NAMES:
            raise ValueError(f"unknown uplink {uplink!r}: use native.RS232 ({RS232}) or native.USB ({USB})")
        if len(self._uplinks) >= MAX_BRIDGES:
            raise ValueError(f"a world has at most {MAX_BRIDGES} bridges")
        i = int(self._lib.urbsim_add_bridge(self._w, uplink))
        if i < 0:
            raise MemoryError("urbsim_add_bridge failed")
        self._uplinks.append(uplink)
        return i

    def add_node(self, bridge: int, app: App, address: int, index: int = 0) -> int:
        """Add a node running `app` at 7-bit I2C `address` on `bridge`'s downlink, with node index
        `index` (0..63) in its identification; returns its number (0, 1, ...)."""
        self._building("add_node")
        self._bridge(bridge)
        try:
            app = App(app)
        except ValueError:
            raise ValueError(f"unknown application {app!r}: one of {', '.join(a.name for a in App)} "
                             "(urb_sim.native.App)") from None
        self._address(address)
        if not 0 <= index <= 63:
            raise ValueError(f"node index {index} does not fit the identification's 6 bits (0..63)")
        if (bridge, address) in self._nodes:
            other = self._nodes.index((bridge, address))
            raise ValueError(f"address 0x{address:02x} on bridge {bridge} is taken by node {other}: every node on "
                             "one downlink needs its own I2C address")
        if len(self._nodes) >= MAX_NODES:
            raise ValueError(f"a world has at most {MAX_NODES} nodes")
        i = int(self._lib.urbsim_add_node(self._w, bridge, int(app), address, index))
        if i < 0:
            raise MemoryError("urbsim_add_node failed")
        self._nodes.append((bridge, address))
        return i

    def trace(self, path: Path | None, mask: int = Trace.ALL) -> None:
        self._open()
        if self._lib.urbsim_trace_open(self._w, str(path).encode() if path else None, mask) != 0:
            raise OSError(f"cannot open trace file {path}")

    def start(self) -> None:
        self._open()
        if self._started:
            raise RuntimeError("start: the world has started already")
        self._now = self._local = None
        if self._lib.urbsim_start(self._w) != 0:
            raise MemoryError("urbsim_start failed")
        self._started = True

    # -- running ----------------------------------------------------------------------------
    def run(self, limit_ns: int) -> bool:
        """Run to `limit_ns` or the next host wake-up (True)."""
        self._running("run")
        self._now = self._local = None
        return bool(self._lib.urbsim_run(self._w, limit_ns) == 1)

    @property
    def now(self) -> int:
        if self._now is None:
            self._open()
            self._now = int(self._lib.urbsim_now(self._w))
        return self._now

    @property
    def events(self) -> int:
        self._open()
        return int(self._lib.urbsim_events(self._w))

    @property
    def trace_hash(self) -> int:
        self._open()
        return int(self._lib.urbsim_trace_hash(self._w))

    @property
    def trace_lines(self) -> int:
        self._open()
        return int(self._lib.urbsim_trace_lines(self._w))

    def flush_trace(self) -> None:
        self._open()
        self._lib.urbsim_trace_flush(self._w)

    # -- host CPU ---------------------------------------------------------------------------
    def host_local(self) -> int:
        if self._local is None:
            self._open()
            self._local = int(self._lib.urbsim_host_local(self._w))
        return self._local

    def host_timer(self, local_ns: int) -> int:
        self._open()
        return int(self._lib.urbsim_host_timer(self._w, local_ns))

    def host_send(self, bridge: int, data: bytes) -> None:
        self._running("host_send")
        self._bridge(bridge)
        buf = (c_uint8 * max(1, len(data))).from_buffer_copy(data.ljust(1, b"\0"))
        if self._lib.urbsim_host_send(self._w, bridge, buf, len(data)) < 0:
            raise ValueError(f"bridge {bridge} refused {len(data)} bytes (unknown bridge or USB queue full)")

    def host_take(self) -> tuple[int, bytes] | None:
        self._open()
        b = c_int(0)
        n = int(self._lib.urbsim_host_take(self._w, ctypes.byref(b), self._buf, len(self._buf)))
        if n < 0:
            return None
        return b.value, ctypes.string_at(self._buf, n)

    def moved(self) -> None:
        """Virtual time moved outside this object (the C host ran the world, urb_sim.chost): forget
        the instant's cached clocks."""
        self._running("run")
        self._now = self._local = None

    def handle(self) -> Any:
        """The C world, for another binding of the same library (urb_sim.chost)."""
        self._running("hand over")
        return self._w

    def run_take(self, limit_ns: int) -> list[tuple[int, bytes]] | None:
        """`run(limit_ns)` and, on a host wake-up, every item `host_take` would hand out then, in the
        same order: None when `limit_ns` was reached (no wake-up), else the items (empty when the
        wake-up found none ready). One call into the library per item instead of one per item plus
        two (the run and the take that finds nothing left)."""
        self._running("run")
        self._now = self._local = None
        n = self._lib.urbsim_run_take(self._w, limit_ns, *self._taken_args)
        if n < 0:
            if n == -1:  # URBSIM_RUN_LIMIT
                return None
            raise RuntimeError("urbsim_run_take refused the call (a bug: the checks above passed)")
        bridge = self._taken_bridge.value
        if bridge < 0:
            return []
        items = [(bridge, ctypes.string_at(self._buf, n))]
        while self._taken_more.value:
            n = self._lib.urbsim_host_take_more(self._w, *self._taken_args)
            if n < 0:
                raise RuntimeError("urbsim_host_take_more found none of the items it counted (a bug in world.c)")
            items.append((self._taken_bridge.value, ctypes.string_at(self._buf, n)))
        return items

    # -- measurements -----------------------------------------------------------------------
    def node_marks(self, node: int) -> list[tuple[int, int, int]]:
        """Drain node `node`'s mark log: (time ns, Mark kind, value)."""
        return self._drain(self._lib.urbsim_node_marks, node)

    def bridge_marks(self, bridge: int) -> list[tuple[int, int, int]]:
        return self._drain(self._lib.urbsim_bridge_marks, bridge)

    def _drain(self, fn: Any, idx: int) -> list[tuple[int, int, int]]:
        self._open()
        out: list[tuple[int, int, int]] = []
        while True:
            n = int(fn(self._w, idx, self._marks_t, self._marks_v, 8192))
            # slices convert a whole block to ints in C: a third of the time of indexing per mark
            values = self._marks_v[:n]
            out.extend(zip(self._marks_t[:n], [v >> 24 for v in values], [v & 0xFFFFFF for v in values]))
            if n < 8192:
                return out

    def node_status(self, node: int) -> NodeStatus:
        self._open()
        arr = (c_int64 * 9)()
        if self._lib.urbsim_node_status(self._w, node, arr) != 0:
            raise IndexError(f"no node {node}")
        return NodeStatus(int(arr[0]), int(arr[1]), int(arr[2]), int(arr[3]), int(arr[4]), int(arr[5]),
                          int(arr[6]), bool(arr[7]), int(arr[8]))

    def plant(self, node: int) -> tuple[float, float, float, float, float, float]:
        """True state of a motor node's motor and leg now: motor angle (rad), speed (rad/s),
        current (A), applied voltage (V), leg angle (rad), case temperature (degC)."""
        self._open()
        arr = (c_double * 6)()
        if self._lib.urbsim_node_plant(self._w, node, arr) != 0:
            raise IndexError(f"node {node} drives no motor")
        return (arr[0], arr[1], arr[2], arr[3], arr[4], arr[5])

    def stat(self, name: str, device: int = 0) -> float:
        self._open()
        return float(self._lib.urbsim_stat(self._w, name.encode(), device))

    # -- native host --------------------------------------------------------------------------
    def native_host(self, bridge: int, period_ticks: int = 1) -> None:
        """Drive `bridge` from the native host traffic model (no Python in the loop), one cycle
        every `period_ticks` OS ticks."""
        self._building("native_host")
        self._bridge(bridge)
        if period_ticks < 1:
            raise ValueError(f"period_ticks must be at least 1 OS tick, got {period_ticks}")
        if self._lib.urbsim_native_host(self._w, bridge, period_ticks) != 0:
            raise MemoryError("urbsim_native_host failed")
        self._native.setdefault(bridge, 0)

    def native_request(self, bridge: int, address: int, mailbox: int, read: bool, length: int, every: int = 1) -> None:
        """Add a request the native host sends to `bridge` every `every` cycles: read (or write) `length`
        bytes of `mailbox` at node `address` (a node that does not exist gets NO_NODE answers)."""
        self._open()
        self._bridge(bridge)
        if bridge not in self._native:
            raise ValueError(f"bridge {bridge} has no native host: call native_host({bridge}) first")
        self._address(address)
        if not 0 <= mailbox <= 7:
            raise ValueError(f"mailbox {mailbox} does not exist: nodes have mailboxes 0..7")
        if not 1 <= length <= 32:
            raise ValueError(f"length {length} is not a mailbox size (1..32 bytes)")
        if every < 1:
            raise ValueError(f"every must be at least 1 (every cycle), got {every}")
        if self._native[bridge] >= MAX_NATIVE_REQUESTS:
            raise ValueError(f"the native host takes at most {MAX_NATIVE_REQUESTS} requests per bridge")
        if self._lib.urbsim_native_request(self._w, bridge, address, mailbox, int(read), length, every) != 0:
            raise RuntimeError("urbsim_native_request refused a checked request")
        self._native[bridge] += 1

    def native_stat(self, bridge: int, name: str) -> float:
        self._open()
        return float(self._lib.urbsim_native_stat(self._w, bridge, name.encode()))

    # -- faults -----------------------------------------------------------------------------
    def i2c_ber(self, bridge: int, ber: float) -> None:
        self._fault("i2c_ber", bridge)
        self._probability("ber", ber)
        self._check(self._lib.urbsim_fault_i2c_ber(self._w, bridge, ber), "i2c_ber")

    def i2c_stuck(self, bridge: int, line: str, duration_ns: int = 0, pulses: int = 0) -> None:
        self._fault("i2c_stuck", bridge)
        lines = {"sda": 0, "scl": 1}
        if line not in lines:
            raise ValueError(f"unknown I2C line {line!r}: 'sda' or 'scl'")
        if duration_ns < 0 or pulses < 0:
            raise ValueError("duration_ns and pulses cannot be negative (0: stuck for good)")
        self._check(self._lib.urbsim_fault_i2c_stuck(self._w, bridge, lines[line], duration_ns, pulses), "i2c_stuck")

    def uart_fault(self, bridge: int, direction: str, ber: float = 0.0, loss: float = 0.0) -> None:
        self._fault("uart_fault", bridge, RS232)
        directions = {"up": 0, "down": 1}
        if direction not in directions:
            raise ValueError(f"unknown direction {direction!r}: 'up' (host to bridge) or 'down' (bridge to host)")
        self._probability("ber", ber)
        self._probability("loss", loss)
        self._check(self._lib.urbsim_fault_uart(self._w, bridge, directions[direction], ber, loss), "uart_fault")

    def usb_loss(self, bridge: int, loss: float) -> None:
        self._fault("usb_loss", bridge, USB)
        self._probability("loss", loss)
        self._check(self._lib.urbsim_fault_usb_loss(self._w, bridge, loss), "usb_loss")

    def node_power(self, node: int, on: bool) -> None:
        self._running("node_power")
        if not 0 <= node < len(self._nodes):
            raise ValueError(f"no node {node}: this world has {len(self._nodes)} (numbered as add_node returned them)")
        self._check(self._lib.urbsim_node_power(self._w, node, int(on)), "node_power")

    def bridge_power(self, bridge: int, on: bool) -> None:
        self._fault("bridge_power", bridge)
        self._check(self._lib.urbsim_bridge_power(self._w, bridge, int(on)), "bridge_power")

    def babble(self, bridge: int, address: int, rate: float) -> None:
        self._fault("babble", bridge)
        self._address(address)
        self._probability("rate", rate)
        self._check(self._lib.urbsim_fault_babble(self._w, bridge, address, rate), "babble")

    # -- argument and phase checks ------------------------------------------------------------
    def _open(self) -> None:
        if not self._w:
            raise RuntimeError("this World is closed; build a new one")

    def _building(self, what: str) -> None:
        self._open()
        if self._started:
            raise RuntimeError(f"{what}: the world has started; build everything before start()")

    def _running(self, what: str) -> None:
        self._open()
        if not self._started:
            raise RuntimeError(f"{what}: call start() first")

    def _bridge(self, bridge: int) -> None:
        if not 0 <= bridge < len(self._uplinks):
            raise ValueError(f"no bridge {bridge}: this world has {len(self._uplinks)} "
                             "(numbered as add_bridge returned them)")

    def _fault(self, what: str, bridge: int, uplink: int | None = None) -> None:
        self._running(what)
        self._bridge(bridge)
        if uplink is not None and self._uplinks[bridge] != uplink:
            raise ValueError(f"{what}: bridge {bridge}'s uplink is {UPLINK_NAMES[self._uplinks[bridge]]}; "
                             f"this fault needs a bridge whose uplink is {UPLINK_NAMES[uplink]}")

    @staticmethod
    def _address(address: int) -> None:
        if not 1 <= address <= 127:
            raise ValueError(f"address {address} is not a 7-bit I2C slave address (1..127)")

    @staticmethod
    def _probability(name: str, value: float) -> None:
        if not 0.0 <= value <= 1.0:  # also refuses NaN
            raise ValueError(f"{name} must be a probability in [0, 1], got {value}")

    @staticmethod
    def _check(rc: int, what: str) -> None:
        if rc != 0:
            raise RuntimeError(f"{what}: the simulation refused arguments that passed the checks (a bug)")
