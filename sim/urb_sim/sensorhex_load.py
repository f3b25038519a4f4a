"""The SensoRHex system of paper Fig. 14 with the host traffic of its experiments, as the host
library's run of the speed benchmark (bench/sim_speed.py) and the run_take test
(tests/sim/test_run_take.py) both drive it: one definition, so that both measure the same load."""

from __future__ import annotations

from collections.abc import Callable

from urb_msgs.sensorhex import MotorCommand, MotorFeedback

from .native import App
from .system import System

#: The RS232 sensors are read every this many ticks (100 Hz at a 1-kHz tick).
SENSOR_TICKS = 10


def wire_sensorhex(s: System) -> tuple[int, int, int]:
    """Add Fig. 14's bridges and nodes to `s` (not started): two USB bridges with three motor driver
    nodes each (indices 0-2 and 3-5), an RS232 bridge with the battery, IMU and IR nodes. Returns
    the bridges (usb0, usb1, rs232)."""
    u0, u1, rs = s.bridge("usb"), s.bridge("usb"), s.bridge("rs232")
    for b, first in ((u0, 0), (u1, 3)):
        for i in range(3):
            s.node(b, App.MOTOR, 0x20 + i, first + i)
    for a, app in ((0x30, App.BATTERY), (0x31, App.IMU), (0x32, App.IR)):
        s.node(rs, app, a, 0)
    return u0, u1, rs


def sensorhex_tick(s: System) -> Callable[[], None]:
    """The host's loop body on a started, wired `s` (wire_sensorhex): each call reads (MotorFeedback)
    and commands (MotorCommand) every motor, and every SENSOR_TICKS-th call reads the three sensors."""
    motors = [s.urb.find_node("MotorDriver", i) for i in range(6)]
    sensors = [s.urb.find_node(n, 0) for n in ("BatteryManager", "Imu", "IrDistance")]
    ticks = [0]

    def tick() -> None:
        ticks[0] += 1
        for m in motors:
            m.submit_request(m.new_request().read_message(MotorFeedback))
            m.submit_request(m.new_request().write_message(MotorCommand(voltage=0)))
        if ticks[0] % SENSOR_TICKS == 0:
            for n in sensors:
                n.submit_request(n.new_request().read(1))

    return tick
