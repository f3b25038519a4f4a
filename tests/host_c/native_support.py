"""What the tests of urb.managers._native share: the extension compiled with one seeded bug, for the
tests that show their comparison catches it (test_native_core.py, test_usb_pump.py,
test_rs232_pump.py), and the pumps' witness (test_usb_pump.py, test_rs232_pump.py)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from urb.api import NodeRequest, URBInterface

REPO = Path(__file__).resolve().parents[2]


def build_native_mutant(tmp: Path, source_name: str, old: str, new: str, *, optimise: bool = False) -> Any:
    """The extension compiled in `tmp` with `old` replaced by `new` in host/urb/managers/`source_name`
    (which must hold `old` exactly once, else the seeded bug no longer applies), loaded as its own
    module. Without `optimise`, -O2 and -flto are left out: quicker to build."""
    sys.path.insert(0, str(REPO / "tools"))
    try:
        import build_native_core as bnc
    finally:
        sys.path.pop(0)
    source = (REPO / "host/urb/managers" / source_name).read_text()
    assert source.count(old) == 1, f"the seeded bug no longer applies to {source_name}: update it"
    mutated = tmp / source_name
    mutated.write_text(source.replace(old, new))
    srcs = [mutated if p.name == source_name else p for p in bnc.sources()]
    out = tmp / bnc.module_path().name
    cmd = [a for a in bnc.compile_command(srcs, out, "mutant") if optimise or a not in ("-O2", "-flto")]
    subprocess.run(cmd, check=True, capture_output=True, text=True)
    spec = importlib.util.spec_from_file_location("_native", out)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def reads_carry_every_seq(urb: URBInterface) -> None:
    """Witness that the pump's sends reach the Python transfers: 30 reads in a row of MotorDriver 0
    complete OK and carry every 4-bit sequence number (the pump writes them back when the dispatcher
    takes the batch)."""
    from urb_msgs import sensorhex as sx

    motor = urb.find_node("MotorDriver", 0)
    reqs = [motor.submit_request(motor.new_request().read_message(sx.MotorFeedback)) for _ in range(30)]
    assert all(r.wait(30) and r.ok for r in reqs)
    seqs = [r._transfer.seq for r in reqs if r._transfer is not None]
    assert len(seqs) == 30 and set(seqs) == set(range(16))


def sensorhex_cycle(urb: URBInterface, cycle: int, imu_every: int) -> list[NodeRequest]:
    """One cycle of the pump scripts' load, submitted: MotorDriver 0..2 each read (MotorFeedback) and
    commanded (MotorCommand, a voltage from `cycle`), and every `imu_every` cycles an IMU read and a
    read the host refuses (HOST_SIZE_MISMATCH)."""
    from urb_msgs import sensorhex as sx

    reqs = []
    for k in range(3):
        node = urb.find_node("MotorDriver", k)
        reqs.append(node.submit_request(node.new_request().read_message(sx.MotorFeedback)))
        reqs.append(node.submit_request(node.new_request().write_message(sx.MotorCommand(voltage=cycle + k))))
    if cycle % imu_every == 0:
        imu = urb.find_node("Imu", 0)
        reqs.append(imu.submit_request(imu.new_request().read_message(sx.ImuSample)))
        reqs.append(imu.submit_request(imu.new_request().read(1, size=3)))
    return reqs
