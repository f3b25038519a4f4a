#!/usr/bin/env python3
"""Flash and RAM of the CAN and RS485 downlink cores on Cortex-M0+ (make size-downlinks).

A node on CAN or RS485 links the node library with its downlink's slave and transfer/framing layer
in place of the I2C slave (firmware/node/urb_i2c.c); the bridge links the master. The 4 KiB flash
budget of the node library holds for the I2C build (make size-node); these numbers say what the
other two builds take, object by object (text = flash, bss = static RAM: none, every core keeps its
state in a caller-owned struct, whose size the probe reports).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

BUILDS = {
    "CAN node (slave + transfer layer + CanWriteRefusal/CanSync codecs)": [
        "firmware/downlink/can/urb_can_slave.o", "firmware/downlink/can/urb_can_transfer.o", "gen/c/urb_can_wire.o"],
    "CAN bridge (master + transfer layer + codecs)": [
        "firmware/downlink/can/urb_can_master.o", "firmware/downlink/can/urb_can_transfer.o", "gen/c/urb_can_wire.o"],
    "RS485 node (slave + framing)": [
        "firmware/downlink/rs485/urb_rs485_slave.o", "firmware/downlink/rs485/urb_rs485_frame.o"],
    "RS485 bridge (master + framing + RS485 codecs)": [
        "firmware/downlink/rs485/urb_rs485_master.o", "firmware/downlink/rs485/urb_rs485_frame.o",
        "gen/c/urb_rs485_wire.o"],
}
STATES = ["can_slave", "can_master", "rs485_slave", "rs485_master"]


def sizes(tool: str, objs: list[Path]) -> dict[str, tuple[int, int, int]]:
    out = subprocess.run([tool, *map(str, objs)], check=True, capture_output=True, text=True).stdout
    rows = {}
    for line in out.splitlines()[1:]:
        f = line.split()
        rows[f[5]] = (int(f[0]), int(f[1]), int(f[2]))
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", default="arm-none-eabi-size")
    ap.add_argument("--nm", default="arm-none-eabi-nm")
    ap.add_argument("--build", type=Path, required=True)
    args = ap.parse_args()
    print("Downlink cores, Cortex-M0+ (-mcpu=cortex-m0plus -mthumb -Os), per build (objects before --gc-sections):")
    for name, objs in BUILDS.items():
        paths = [args.build / o for o in objs]
        rows = sizes(args.size, paths)
        text = sum(r[0] for r in rows.values())
        ram = sum(r[1] + r[2] for r in rows.values())
        parts = ", ".join(f"{Path(o).stem} {rows[str(p)][0]}" for o, p in zip(objs, paths))
        print(f"  {name:<70} flash {text:5d} B, static RAM {ram} B   ({parts})")
    probe = args.build / "tests/firmware/downlink_size_probe.o"
    nm = subprocess.run([args.nm, "-S", str(probe)], check=True, capture_output=True, text=True).stdout
    state = {f[3].removeprefix("probe_"): int(f[1], 16) for f in (ln.split() for ln in nm.splitlines()) if len(f) == 4}
    print("State (caller-owned structs): " + ", ".join(f"{k} {state[k]} B" for k in STATES))
    missing = [k for k in STATES if k not in state]
    if missing:
        print(f"size-downlinks: the probe lacks {missing}", file=sys.stderr)
        return 1
    print("The node library's 4 KiB flash budget applies to the I2C build (make size-node); no budget is set for these.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
