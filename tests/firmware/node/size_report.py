#!/usr/bin/env python3
"""Flash and RAM of the node library and of each SensoRHex Cortex-M0+ image (make size-node).

Library: the four library objects (arm-none-eabi-size), the single-node adapter apart, and the
RAM one node needs: sizeof(urb_node_t) from the size probe, split into node state and the mailbox-0
buffers it embeds (mailboxes 1..7 live in the caller's storage block).

Images: the kept input sections of the linker map, summed per component, so the library's share
of a real image (after --gc-sections) is visible next to the codecs, the app, the port and libc.

The three budgets are also written as the evidence record build/evidence/size.json
(report/urb_report/records.py): size:node/library-flash, size:node/state-ram, size:node/no-static-data.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

BUDGET_FLASH = 4096
BUDGET_RAM = 256


def size_objects(size_tool: str, objs: list[str]) -> list[tuple[str, int, int, int]]:
    out = subprocess.run([size_tool, *objs], check=True, capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines()[1:]:
        f = line.split()
        rows.append((Path(f[5]).name, int(f[0]), int(f[1]), int(f[2])))
    return rows


def nm_sizes(obj: str) -> dict[str, int]:
    nm = "arm-none-eabi-nm"
    out = subprocess.run([nm, "-S", obj], check=True, capture_output=True, text=True).stdout
    sizes = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) == 4:
            sizes[f[3]] = int(f[1], 16)
    return sizes


def component(path: str) -> str:
    path = path.split("/obj/", 1)[-1]  # drop the build prefix (build/firmware/node/...)
    if path.startswith("firmware/node/") or "liburb_node.a" in path:
        return "library"
    if path.startswith("gen/c/"):
        return "codecs"
    if path.startswith(("firmware/apps/sensorhex/targets/", "firmware/hal/cortex-m0plus/")):
        return "port+board"
    if path.startswith("firmware/apps/sensorhex/"):
        return "app"
    return "libc/libgcc"


SECTION = re.compile(r"^ (\.(?:text|rodata|data|bss|isr_vector)\S*)\s*(0x[0-9a-f]+)?\s*(0x[0-9a-f]+)?\s*(\S+)?")


def map_components(map_file: Path) -> dict[str, dict[str, int]]:
    """Kept input sections per component: {'library': {'flash': n, 'ram': m}, ...}."""
    text = map_file.read_text()
    start = text.find("Linker script and memory map")
    lines = text[start:].splitlines()
    result: dict[str, dict[str, int]] = {}
    i = 0
    while i < len(lines):
        m = SECTION.match(lines[i])
        if m:
            name, addr, size, src = m.groups()
            if addr is None and i + 1 < len(lines):  # long name: the rest is on the next line
                nxt = lines[i + 1].split()
                if len(nxt) >= 3 and nxt[0].startswith("0x"):
                    addr, size, src = nxt[0], nxt[1], nxt[2]
                    i += 1
            if addr and size and src and int(addr, 16) != 0:
                n = int(size, 16)
                kind = component(src)
                slot = result.setdefault(kind, {"flash": 0, "ram": 0})
                if name.startswith((".text", ".rodata", ".isr_vector")):
                    slot["flash"] += n
                elif name.startswith(".data"):
                    slot["flash"] += n
                    slot["ram"] += n
                else:
                    slot["ram"] += n
        i += 1
    return result


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--size", default="arm-none-eabi-size")
    ap.add_argument("--lib", nargs="+", required=True)
    ap.add_argument("--single", required=True)
    ap.add_argument("--probe", required=True)
    ap.add_argument("--images", nargs="+", required=True)
    args = ap.parse_args()

    rows = size_objects(args.size, args.lib)
    print("Node library, Cortex-M0+ (-mcpu=cortex-m0plus -mthumb -Os), per object:")
    print(f"  {'object':<18}{'text':>7}{'data':>7}{'bss':>7}")
    total_flash = 0
    static = []
    for name, text, data, bss in rows:
        print(f"  {name:<18}{text:>7}{data:>7}{bss:>7}")
        total_flash += text + data
        if data or bss:
            print(f"  error: {name} has static data: the library must keep no state of its own")
            static.append(f"{name}: data {data} B, bss {bss} B")
    if static:
        write_evidence(args.size, [_budget("no-static-data", "0 B of static data in every library object",
                                           "; ".join(static), False)])
        return 1
    single = size_objects(args.size, [args.single])[0]
    probe = nm_sizes(args.probe)
    node_size = probe["urb_probe_node"]
    mb0 = probe["urb_probe_mb0"]
    state = node_size - mb0
    print(f"  {'total':<18}{total_flash:>7}{0:>7}{0:>7}")
    print(f"  (single-node adapter urb_single.o: text {single[1]}, bss {single[3]}: the one global node + storage)")
    print()
    print(f"RAM per node: sizeof(urb_node_t) = {node_size} B = {state} B state + {mb0} B mailbox-0 buffers;"
          f" mailboxes 1..7: 2 x size each, in the caller's storage block")
    print(f"Node state RAM: {state} B (budget {BUDGET_RAM} B besides mailbox buffers)"
          f" -> {'OK' if state < BUDGET_RAM else 'OVER BUDGET'}")
    print()
    kinds = ["library", "codecs", "app", "port+board", "libc/libgcc"]
    print("SensoRHex images (kept sections after --gc-sections; flash = text+rodata+data, RAM = data+bss):")
    header = f"  {'image':<20}" + "".join(f"{k:>13}" for k in kinds) + f"{'flash':>8}{'RAM':>7}"
    print(header)
    status = 0
    lib_in_image = []
    for image in args.images:
        comps = map_components(Path(image).with_suffix(".map"))
        out = subprocess.run([args.size, image], check=True, capture_output=True, text=True).stdout.splitlines()[1]
        text, data, bss = (int(x) for x in out.split()[:3])
        cells = "".join(f"{comps.get(k, {}).get('flash', 0):>13}" for k in kinds)
        print(f"  {Path(image).stem:<20}{cells}{text + data:>8}{data + bss:>7}")
        lib_in_image.append(comps.get("library", {}).get("flash", 0))
    print("  (per-component columns: flash bytes; the RAM column includes the node, its storage block and the port)")
    print()
    linked = max(lib_in_image)
    print(f"Library flash linked into an image: at most {linked} B (budget {BUDGET_FLASH} B)"
          f" -> {'OK' if linked < BUDGET_FLASH else 'OVER BUDGET'}; all objects: {total_flash} B"
          f" (includes status/size getters no image links)")
    if state >= BUDGET_RAM or linked >= BUDGET_FLASH:
        status = 1
    write_evidence(args.size, [
        _budget("no-static-data", "0 B of static data in every library object", "0 B in every object", True),
        _budget("library-flash", f"< {BUDGET_FLASH} B of library flash in the largest image",
                f"{linked} B (all objects: {total_flash} B)", linked < BUDGET_FLASH),
        _budget("state-ram", f"< {BUDGET_RAM} B of node state besides mailbox buffers",
                f"{state} B (sizeof(urb_node_t) = {node_size} B with {mb0} B mailbox-0 buffers)", state < BUDGET_RAM)])
    return status


def _budget(name: str, expected: str, measured: str, ok: bool) -> Any:
    from urb_report.records import Item

    return Item(id=f"size:node/{name}", kind="budget", verdict="pass" if ok else "fail", expected=expected,
                measured=measured, source="tests/firmware/node/size_report.py", rerun="make size-node")


def write_evidence(size_tool: str, items: list[Any]) -> None:
    """The budgets as the evidence record build/evidence/size.json, for the certification report."""
    from urb_report.records import command_version, write_record

    write_record("size", items, {"arm-none-eabi-gcc": command_version(["arm-none-eabi-gcc", "--version"]),
                                 "arm-none-eabi-size": command_version([size_tool, "--version"])},
                 config={"flags": "-mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections, --gc-sections",
                         "budget_flash_B": BUDGET_FLASH, "budget_ram_B": BUDGET_RAM})


if __name__ == "__main__":
    sys.exit(main())
