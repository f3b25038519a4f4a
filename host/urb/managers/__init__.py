"""Bus managers: one per bridge, each a sans-IO protocol core driven by a runtime adapter.

* `RS232Manager(port, baud)`: a serial port, real time (reader, writer and dispatcher threads);
* `USBManager(transport)`: a USB uplink over a pluggable `FrameTransport`, 1-ms batches;
* `SimManager(clock, transport)`: either core driven by a `Clock` (the simulation, virtual time).

The protocol cores (`Rs232Core`, `UsbCore`) and the `BridgeModel` test double are importable for
tests and tools; see host/urb/README.md for the interfaces.
"""

from .base import (
    BusManager,
    ByteTransport,
    Clock,
    DrivableClock,
    FrameTransport,
    ManagerStats,
    Transfer,
)
from .loopback import BridgeModel, FakeNode, fake_node
from .rs232 import RS232Manager
from .rs232_core import Rs232Core
from .sim import LoopbackByteTransport, LoopbackFrameTransport, SimManager, VirtualClock
from .usb import CharDeviceTransport, LoopbackUsbTransport, USBManager
from .usb_core import UsbCore

__all__ = [
    "BridgeModel",
    "BusManager",
    "ByteTransport",
    "CharDeviceTransport",
    "Clock",
    "DrivableClock",
    "FakeNode",
    "FrameTransport",
    "LoopbackByteTransport",
    "LoopbackFrameTransport",
    "LoopbackUsbTransport",
    "ManagerStats",
    "RS232Manager",
    "Rs232Core",
    "SimManager",
    "Transfer",
    "USBManager",
    "UsbCore",
    "VirtualClock",
    "fake_node",
]
