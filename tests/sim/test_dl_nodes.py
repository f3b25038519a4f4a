"""The nodes of the CAN and RS485 downlink models are URB nodes (sim/downlink/sim_dl_node.c): the node
library on the downlink's slave, running the SensoRHex applications the I2C world runs, the same
objects in the same library; and a seeded bug in the node library's downlink adapter (urb_node_dl.c)
makes a criterion of the CAN experiment fail."""

from __future__ import annotations

import ctypes
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from urb_sim import build, native
from urb_sim.fieldbus import cores, cycle, measure, rs485

APP_HOOKS = {"probe": "sim_probe_hooks", "motor": "sensorhex_motor_hooks", "battery": "sensorhex_battery_hooks",
             "imu": "sensorhex_imu_hooks", "ir": "sensorhex_ir_hooks"}


def test_one_library_holds_the_applications_for_every_downlink() -> None:
    """liburbsim.so compiles each application source once, beside the I2C world's node port
    (node_hal_sim.c, sensorhex_io_sim.c) and the CAN/RS485 node port (sim_dl_node.c); the downlink
    models load that very file, which defines each application's hooks exactly once."""
    names = [p.relative_to(build.REPO).as_posix() for p in build.sources()]
    apps = [n for n in names if n.startswith("firmware/apps/sensorhex/")]
    assert sorted(apps) == sorted(set(apps)) and len(apps) == 4
    for port in ("firmware/hal/sim/node_hal_sim.c", "firmware/hal/sim/sensorhex_io_sim.c", "firmware/hal/sim/sim_apps.c",
                 "sim/downlink/sim_dl_node.c", "firmware/node/urb_node_dl.c", "firmware/node/urb_i2c.c"):
        assert names.count(port) == 1, port
    assert cores.lib()._name == native.lib()._name == str(build.library_path())
    nm = subprocess.run(["nm", "-D", "--defined-only", str(build.library_path())], capture_output=True, text=True,
                        check=True).stdout.split()
    for symbol in APP_HOOKS.values():
        assert nm.count(symbol) == 1, symbol


@pytest.mark.parametrize("app", sorted(APP_HOOKS))
def test_a_node_on_can_and_on_rs485_calls_the_library_s_application_object(app: str) -> None:
    """The hooks the node library calls on either downlink are the library's one object of the
    application (the I2C world binds the same symbol in sensorhex_io_sim.c / node_hal_sim.c)."""
    symbol = ctypes.addressof(ctypes.c_char.in_dll(cores.lib(), APP_HOOKS[app]))
    spec = cores.App(app, out_size=4 if app == "probe" else 0)
    on_can = cores.CanNode(7, 1_000_000, spec)
    on_rs485 = cores.Rs485Node(7, rs485.timing(1_000_000), 0, spec)
    assert on_can.hooks() == on_rs485.hooks() == symbol


def test_the_applications_run_and_publish_their_layouts() -> None:
    """Witness: each SensoRHex application's update runs on the node (heartbeats pass) and a read of
    its outbox 1 returns its published layout (MotorFeedback's encoder, a battery's pack voltage)."""
    apps = {1: cores.App("motor"), 10: cores.App("battery"), 11: cores.App("imu"), 12: cores.App("ir")}
    d = cycle.CanDownlink(1_000_000, __import__("random").Random(1), tuple(apps), apps=apps)
    motor = d.slaves[1]
    motor.motor_sample(1234)
    sizes = {1: measure.FEEDBACK_BYTES, **{a: n for a, _, n in measure.SENSORS}}
    got = {a: d.transact(25_000.0 + 1000.0 * i, cycle.Txn(a, 1, True, bytes(sizes[a]))) for i, a in enumerate(apps)}
    assert {a: r.status for a, r in got.items()} == {a: "OK" for a in apps}
    assert got[1].data[:2] == (1234).to_bytes(2, "little")
    assert int.from_bytes(got[10].data[:2], "little") == 12300  # pack 0's voltage, mV
    assert all(d.slaves[a].beats() >= 25 for a in apps) and d.mismatches == []


def _run_can_control(mutant: str, tmp_path: Path) -> dict[str, bool]:
    """The CAN experiment's control criteria with the node library built with seeded bug `mutant`,
    in a process of its own (the library is loaded once per process)."""
    code = (
        "import json, sys\n"
        "from pathlib import Path\n"
        "from urb_sim.experiments import Result, downlinks\n"
        "r = Result('can', 't', 'p')\n"
        "downlinks._control(r, 'can', 1_000_000, 0.3, 1)\n"
        "print(json.dumps({c.name: c.passed for c in r.checks}))\n"
    )
    env = {**os.environ, "URBSIM_MUTANT": mutant} if mutant else {k: v for k, v in os.environ.items()
                                                                    if k != "URBSIM_MUTANT"}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, cwd=tmp_path,
                          check=False, timeout=900)
    assert proc.returncode == 0, proc.stderr
    result: dict[str, bool] = json.loads(proc.stdout.strip().splitlines()[-1])
    return result


@pytest.fixture(scope="module")
def clean_control(tmp_path_factory: pytest.TempPathFactory) -> dict[str, bool]:
    return _run_can_control("", tmp_path_factory.mktemp("clean"))


@pytest.mark.parametrize(("mutant", "criterion"), [
    ("NODE_DL_FRONT_BUFFER", "transactions carry the node library's mailboxes"),
    ("NODE_DL_NO_SYNC", "motor node heartbeats locked to SYNC"),
])
def test_a_seeded_bug_in_the_node_library_s_can_adapter_fails_a_criterion(mutant: str, criterion: str,
                                                                           clean_control: dict[str, bool],
                                                                           tmp_path: Path) -> None:
    """urb_node_dl.c's seeded bugs (URB_MUTANT_NODE_DL_*, also caught by tests/firmware/node_dl): a write
    filled into the buffer the application may hold; SYNC not passed to the PLL. The criterion that
    catches each passes without it."""
    assert clean_control[criterion] and all(clean_control.values()), clean_control
    assert not _run_can_control(mutant, tmp_path)[criterion]
