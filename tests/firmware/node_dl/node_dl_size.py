#!/usr/bin/env python3
"""Flash of the node library per downlink on Cortex-M0+ (make size-node-downlinks).

The node library's archive is built once per downlink (mk/node_downlinks.mk, URB_DOWNLINK): the
mailbox, PLL, lifecycle and observation objects are shared; I2C adds its slave (urb_i2c.c), CAN
and RS485 the mailbox table (urb_node_dl.c), the attach function and the downlink's slave and
transfer/framing layer. The 4 KiB budget holds for the I2C build and is checked by make size-node on
the library's share of the linked SensoRHex images (the object totals here include getters no image
links); the CAN and RS485 builds are reported. Any build with static data fails (every part keeps
its state in caller-owned structs).
"""
from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path



def archive_sizes(size_tool: str, archive: Path) -> list[tuple[str, int, int, int]]:
    """(object, text, data, bss) of every member of `archive`."""
    out = subprocess.run([size_tool, str(archive)], check=True, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines()[1:]:
        f = line.split()
        rows.append((f[5].split(" ")[0], int(f[0]), int(f[1]), int(f[2])))
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", default="arm-none-eabi-size")
    ap.add_argument("--build", type=Path, required=True)
    ap.add_argument("--archive", action="append", default=[], help="DOWNLINK=PATH of its liburb_node.a")
    args = ap.parse_args()
    print("Node library per downlink, Cortex-M0+ (-Os, objects before --gc-sections):")
    failed = False
    for spec in args.archive:
        name, _, path = spec.partition("=")
        rows = archive_sizes(args.size, Path(path))
        flash = sum(r[1] + r[2] for r in rows)
        static_ram = sum(r[2] + r[3] for r in rows)
        parts = ", ".join(f"{Path(r[0]).stem} {r[1]}" for r in rows)
        note = " (the 4 KiB budget: make size-node, linked images)" if name == "i2c" else ""
        if static_ram != 0:
            print(f"size-node-downlinks: the {name} node library has {static_ram} B of static data; libraries "
                  "keep their state in caller-owned structs: move it there", file=sys.stderr)
            failed = True
        print(f"  {name:<6} flash {flash:5d} B{note}, static RAM {static_ram} B   ({parts})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
