"""Assemble a simulated URB system: a `World` (C), its `SimHost` (the CPU) and one host-library
`SimManager` per bridge, registered with a `URBInterface` — the same application code that runs on
the robot then runs in virtual time.

    sysm = System(seed=1)
    b = sysm.bridge("usb")
    sysm.node(b, App.MOTOR, 0x10, index=0)
    sysm.start()                       # power on, discovery through the real host library
    motor = sysm.urb.find_node("MotorDriver", 0)
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from urb.api import BridgeReport, URBInterface
from urb.managers.sim import SimManager
from urb_msgs import NODES, NodeInfo

from .host import SimHost
from .native import RS232, USB, App, World
from .probe import probe_fingerprint, probe_info

NS_PER_MS = 1_000_000
NS_PER_S = 1_000_000_000


class SimulationError(RuntimeError):
    """The simulated system did not come up (discovery failed); the message says why."""


@dataclass
class System:
    """One simulated system and the host software driving it."""

    seed: int = 1
    params: dict[str, float] = field(default_factory=dict)
    probe_out: int = 6
    probe_in: int = 0
    extra_schema: list[NodeInfo] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.world = World(self.seed)
        self.world.set("probe.out_size", self.probe_out)
        self.world.set("probe.in_size", self.probe_in)
        self.world.set("probe.fingerprint", probe_fingerprint(self.probe_out, self.probe_in))
        for k, v in self.params.items():
            self.world.set(k, v)
        self.host = SimHost(self.world)
        self.bridges: list[tuple[int, str]] = []
        self.nodes: list[tuple[int, int, App, int, int]] = []  # (id, bridge, app, address, index)
        self.managers: dict[int, SimManager] = {}
        self.reports: dict[int, BridgeReport] = {}
        schema: list[NodeInfo] = [i for i in NODES.values() if i.kind == "node"]
        schema.append(probe_info(self.probe_out, self.probe_in))
        schema.extend(self.extra_schema)
        self.urb = URBInterface(schema=schema)

    def set(self, name: str, value: float) -> None:
        """Set a parameter for the devices added after this call."""
        self.world.set(name, value)

    def bridge(self, uplink: str) -> int:
        """Add a bridge with an "rs232" or "usb" uplink; returns its id."""
        kind = {"rs232": RS232, "usb": USB}.get(uplink)
        if kind is None:
            raise ValueError(f"uplink {uplink!r}: use 'rs232' or 'usb'")
        b = self.world.add_bridge(kind)
        self.bridges.append((b, uplink))
        return b

    def node(self, bridge: int, app: App, address: int, index: int = 0) -> int:
        n = self.world.add_node(bridge, app, address, index)
        self.nodes.append((n, bridge, app, address, index))
        return n

    def start(self, *, settle_ms: float = 60.0, discover: bool = True, rescan: bool = True,
              window: int | None = None, before_discovery: Callable[[], None] | None = None) -> None:
        """Power everything on, let the bridges scan and the nodes lock (settle_ms of virtual
        time), run `before_discovery` (e.g. power a node off), then run discovery on every bridge
        through `URBInterface.start_discovery`."""
        self.world.start()
        self.host.advance(int(settle_ms * NS_PER_MS))
        if before_discovery is not None:
            before_discovery()
        for b, uplink in self.bridges:
            transport = self.host.usb(b) if uplink == "usb" else self.host.rs232(b)
            self.managers[b] = SimManager(self.host, transport, name=f"{uplink}{b}")
        if not discover:
            for mgr in self.managers.values():
                mgr.start()
            return
        pending = dict(self.managers)
        for b, mgr in self.managers.items():
            self.urb.start_discovery(mgr, self._reporter(b), rescan=rescan)
        ok = self.host.run_until(lambda: len(self.reports) == len(pending), self.host.now_ns() + 2 * NS_PER_S)
        if not ok:
            raise SimulationError("discovery did not finish within 2 s of virtual time on: "
                                  + ", ".join(m.name for b, m in pending.items() if b not in self.reports))
        errors = [f"{self.managers[b].name}: {r.error}" for b, r in self.reports.items() if r.error]
        if errors:
            raise SimulationError("discovery failed: " + "; ".join(errors))
        if window is not None:
            for mgr in self.managers.values():
                mgr.set_window(window)

    def _reporter(self, bridge: int) -> Callable[[BridgeReport], None]:
        def store(report: BridgeReport) -> None:
            self.reports[bridge] = report
        return store

    def close(self) -> None:
        self.world.close()


class Loop:
    """A periodic application thread: `fn()` runs once per period of the host clock, woken by
    the OS tick like a thread sleeping with clock_nanosleep(TIMER_ABSTIME)."""

    def __init__(self, host: SimHost, period_ns: int, fn: Callable[[], None], count: int | None = None) -> None:
        self.host = host
        self.period = period_ns
        self.fn = fn
        self.left = count
        self.runs = 0
        self.next = (host.now_ns() // period_ns + 1) * period_ns
        host.call_at(self.next, self._run)

    def _run(self) -> None:
        if self.left is not None:
            if self.left <= 0:
                return
            self.left -= 1
        self.runs += 1
        self.fn()
        self.next += self.period
        now = self.host.now_ns()
        while self.next <= now:
            self.next += self.period  # overran: skip the missed periods, like a real thread
        self.host.call_at(self.next, self._run)

    def stop(self) -> None:
        self.left = 0
