"""The firmware's PRIMASK critical sections, measured from the Cortex-M0+ build (issue #40).

An interrupt raised while the core runs with PRIMASK set waits until the section ends: the longest
section is part of the worst-case interrupt latency, and the hardware profiles (sim/profiles) take
`node.mask_cycles` and `bridge.mask_cycles` from here, not from a guess.

For every `cpsid i` in the node image (`build/firmware/node/cortex-m0plus/sensorhex_motor.elf`, the
port `firmware/hal/cortex-m0plus/urb_hal_cm0.c`) and in the bridge image
(`build/firmware/urb-bridge-cm0plus.elf`, `bridge_port.c`), the section runs from the instruction
after it to the one that unmasks (`cpsie i`, or `msr PRIMASK` restoring the saved value), through
every function it calls. Its worst path is the longest over every branch, each loop taken as often
as its bound allows (LOOP_BOUNDS: the bound the C source states, checked against that source), in
Cortex-M0+ cycles (CYCLES: the Cortex-M0+ Technical Reference Manual's instruction timings, zero
wait states) plus, per flash wait state, one cycle per 32-bit instruction fetch on that path (a new
word, or the target of a taken branch: no cache or prefetch hit, conservative).

    python3 -m urb_sim.critical            # print the table measured from the images
    python3 -m urb_sim.critical --write    # write sim/profiles/critical_sections.json
    python3 -m urb_sim.critical --check    # fail when the committed table differs (make sim-critical-check)
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .build import REPO

TABLE = REPO / "sim" / "profiles" / "critical_sections.json"
#: (device, image, port source that holds the sections)
IMAGES = [("node", REPO / "build" / "firmware" / "node" / "cortex-m0plus" / "sensorhex_motor.elf",
           "firmware/hal/cortex-m0plus/urb_hal_cm0.c"),
          ("bridge", REPO / "build" / "firmware" / "urb-bridge-cm0plus.elf",
           "firmware/hal/cortex-m0plus/bridge_port.c")]
OBJDUMP = "arm-none-eabi-objdump"

#: Loops on a section's path: function -> (iterations at most, the C source file, the comment that
#: states the bound there). A backward branch in a function not listed here is an error.
LOOP_BOUNDS: dict[str, tuple[int, str, str]] = {
    "urb_node_has_work": (4, "firmware/node/urb_node.c", "bound: URB_NODE_FAULT_CODES = 4"),
}

#: Cortex-M0+ cycles per instruction (ARM DDI 0484C, Cortex-M0+ TRM, 3.3 "Instruction set summary",
#: single-cycle I/O and multiplier as on the STM32G0): (base, per register in the list). Branches:
#: `b<cond>` 2 taken / 1 not, `b` 2, `bl` 3, `bx`/`blx` 2; POP with PC 3 + N.
CYCLES: dict[str, tuple[int, int]] = {
    "ldr": (2, 0), "ldrb": (2, 0), "ldrh": (2, 0), "ldrsb": (2, 0), "ldrsh": (2, 0),
    "str": (2, 0), "strb": (2, 0), "strh": (2, 0),
    "push": (1, 1), "pop": (1, 1), "ldmia": (1, 1), "ldm": (1, 1), "stmia": (1, 1), "stm": (1, 1),
    "mrs": (3, 0), "msr": (3, 0), "isb": (3, 0), "dsb": (3, 0), "dmb": (3, 0),
    "wfi": (2, 0), "wfe": (2, 0), "bl": (3, 0), "bx": (2, 0), "blx": (2, 0), "b": (2, 0),
}
ONE_CYCLE = {"movs", "mov", "adds", "add", "subs", "sub", "adcs", "sbcs", "rsbs", "negs", "cmp", "cmn", "tst",
             "ands", "orrs", "eors", "bics", "mvns", "lsls", "lsrs", "asrs", "rors", "muls", "uxtb", "uxth",
             "sxtb", "sxth", "rev", "rev16", "revsh", "cpsid", "cpsie", "nop", "adr"}
CONDITIONAL = re.compile(r"^b(eq|ne|cs|hs|cc|lo|mi|pl|vs|vc|hi|ls|ge|lt|gt|le)(\.n|\.w)?$")


class CriticalError(RuntimeError):
    """The images cannot be measured (missing, unknown instruction, unbounded loop): says why."""


@dataclass(frozen=True)
class Insn:
    addr: int
    size: int
    op: str
    args: str


def disassemble(elf: Path) -> dict[str, list[Insn]]:
    """Function name -> its instructions, from `objdump -d` of `elf` (literal pools left out)."""
    if not elf.exists():
        raise CriticalError(f"{elf} does not exist: build it first (make cross-firmware-node "
                            "build/firmware/urb-bridge-cm0plus.elf)")
    try:
        text = subprocess.run([OBJDUMP, "-d", str(elf)], capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as exc:
        raise CriticalError(f"{OBJDUMP} -d {elf} failed: {exc}") from exc
    return parse(text)


def parse(text: str) -> dict[str, list[Insn]]:
    """Parse objdump's disassembly: function name -> instructions in address order."""
    funcs: dict[str, list[Insn]] = {}
    current: list[Insn] | None = None
    for line in text.splitlines():
        head = re.match(r"^([0-9a-f]+) <([^>]+)>:$", line)
        if head:
            current = funcs.setdefault(head.group(2), [])
            continue
        m = re.match(r"^\s*([0-9a-f]+):\s+((?:[0-9a-f]{4} ?){1,2})\s+(\S+)\s*(.*)$", line)
        if m is None or current is None:
            continue
        op = m.group(3)
        if op.startswith("."):
            continue  # .word, .short: a literal pool
        size = 2 * len(m.group(2).split())
        current.append(Insn(int(m.group(1), 16), size, op, m.group(4).split("@")[0].strip()))
    return funcs


def _target(args: str) -> int:
    m = re.match(r"^([0-9a-f]+)", args)
    if m is None:
        raise CriticalError(f"branch without a target address: {args!r}")
    return int(m.group(1), 16)


def _cost(insn: Insn, taken: bool) -> int:
    op = insn.op.split(".")[0]
    if CONDITIONAL.match(insn.op):
        return 2 if taken else 1
    if op in ONE_CYCLE:
        return 1
    if op in CYCLES:
        base, per = CYCLES[op]
        regs = len(re.findall(r"r\d+|lr|pc|sp", insn.args.split("{", 1)[1])) if "{" in insn.args else 0
        if op == "pop" and "pc" in insn.args:
            return 3 + regs
        return base + per * regs
    raise CriticalError(f"no Cortex-M0+ cycle count for {insn.op!r} at {insn.addr:#x}: add it to CYCLES")


@dataclass
class Path_:
    """The worst path found: cycles at 0 wait states, 32-bit fetches, instructions executed."""

    cycles: int = 0
    fetches: int = 0
    insns: int = 0

    def add(self, other: Path_) -> Path_:
        return Path_(self.cycles + other.cycles, self.fetches + other.fetches, self.insns + other.insns)

    def key(self) -> tuple[int, int, int]:
        return (self.cycles, self.fetches, self.insns)


def _fetch(insn: Insn, after_jump: bool) -> int:
    """1 when executing `insn` needs a new 32-bit fetch: a word boundary, or a jump landed here."""
    return 1 if after_jump or insn.addr % 4 == 0 or insn.size == 4 else 0


def _is_end(insn: Insn) -> bool:
    return insn.op == "cpsie" or (insn.op == "msr" and "PRIMASK" in insn.args.upper())


def worst(funcs: dict[str, list[Insn]], func: str, start: int, *, to_unmask: bool,
          stack: tuple[str, ...] = ()) -> Path_:
    """The worst path in `func` from the instruction at `start` to the end: the unmasking instruction
    (to_unmask) or the function's return, through the functions it calls."""
    if func in stack:
        raise CriticalError(f"recursion through {' -> '.join(stack + (func,))}")
    insns = funcs.get(func)
    if not insns:
        raise CriticalError(f"function {func} is not in the image")
    index = {i.addr: k for k, i in enumerate(insns)}
    bound = LOOP_BOUNDS.get(func, (0, "", ""))[0]
    best: Path_ | None = None

    def step(k: int, back: int, after_jump: bool, acc: Path_, seen: frozenset[int]) -> None:
        nonlocal best
        while True:
            if k >= len(insns):
                raise CriticalError(f"{func}: the path runs off the end of the function")
            insn = insns[k]
            seen = seen | {insn.addr}
            fetch = _fetch(insn, after_jump)
            after_jump = False
            op = insn.op.split(".")[0]
            if to_unmask and _is_end(insn):
                acc = acc.add(Path_(_cost(insn, False), fetch, 1))
                if best is None or acc.key() > best.key():
                    best = acc
                return
            if op == "bl":
                callee = re.search(r"<([^>+]+)>", insn.args)
                if callee is None:
                    raise CriticalError(f"{func}: call without a target at {insn.addr:#x}")
                inner = worst(funcs, callee.group(1), funcs[callee.group(1)][0].addr, to_unmask=False,
                              stack=stack + (func,))
                acc = acc.add(Path_(_cost(insn, True), fetch, 1)).add(inner)
                after_jump = True  # the return lands here
                k += 1
                continue
            if (op == "pop" and "pc" in insn.args) or (op == "bx" and insn.args == "lr"):
                if to_unmask:
                    raise CriticalError(f"{func} returns at {insn.addr:#x} with interrupts still masked")
                acc = acc.add(Path_(_cost(insn, True), fetch, 1))
                if best is None or acc.key() > best.key():
                    best = acc
                return
            if CONDITIONAL.match(insn.op) or op == "b":
                target = _target(insn.args)
                if target not in index:
                    raise CriticalError(f"{func}: branch at {insn.addr:#x} leaves the function")
                loop = target in seen  # back to code this path already ran: a loop, not a shared tail
                if loop and bound == 0:
                    raise CriticalError(f"{func} has a loop (branch back at {insn.addr:#x}) without a bound in "
                                        "LOOP_BOUNDS: add its bound as the C source states it")
                # a loop of `bound` iterations branches back bound - 1 times
                can_take = not loop or back < bound - 1
                if CONDITIONAL.match(insn.op):
                    # not taken: fall through
                    step(k + 1, back, False, acc.add(Path_(_cost(insn, False), fetch, 1)), seen)
                    if can_take:
                        step(index[target], back + loop, True, acc.add(Path_(_cost(insn, True), fetch, 1)), seen)
                    return
                if not can_take:
                    return  # an unconditional loop beyond its bound: not a path
                acc = acc.add(Path_(_cost(insn, True), fetch, 1))
                k, back, after_jump = index[target], back + loop, True
                continue
            acc = acc.add(Path_(_cost(insn, False), fetch, 1))
            k += 1

    step(index[start], 0, True, Path_(), frozenset())
    if best is None:
        raise CriticalError(f"{func}: no path from {start:#x} to its end")
    return best


def _check_bounds() -> None:
    """Every loop bound used must still be stated in its C source."""
    for func, (count, source, comment) in LOOP_BOUNDS.items():
        text = (REPO / source).read_text(encoding="utf-8")
        if comment not in text:
            raise CriticalError(f"{source} no longer says {comment!r} (the bound of {func}'s loop, {count} "
                                "iterations, in urb_sim/critical.py LOOP_BOUNDS): update the bound")


def sections(funcs: dict[str, list[Insn]], device: str, source: str) -> list[dict[str, Any]]:
    """Every PRIMASK section of one image, worst path first."""
    found: list[dict[str, Any]] = []
    for name, insns in funcs.items():
        for k, insn in enumerate(insns):
            if insn.op != "cpsid":
                continue
            if k + 1 >= len(insns):
                raise CriticalError(f"{name}: cpsid i is its last instruction")
            p = worst(funcs, name, insns[k + 1].addr, to_unmask=True)
            found.append({"id": f"{device}:{name}", "device": device, "function": name, "source": source,
                          "cycles": p.cycles, "fetches": p.fetches, "instructions": p.insns})
    if not found:
        raise CriticalError(f"no cpsid i in the {device} image: the port's critical sections were not found")
    found.sort(key=lambda s: (-s["cycles"], s["id"]))
    return found


def measure() -> dict[str, Any]:
    """The table: every section of the node and bridge images, and the worst per device."""
    _check_bounds()
    table: dict[str, Any] = {"about": "Generated by `python3 -m urb_sim.critical --write` from the Cortex-M0+ images "
                                      "(make cross-firmware-node, build/firmware/urb-bridge-cm0plus.elf); "
                                      "`make sim-critical-check` fails when it is stale. cycles: the worst path "
                                      "from the instruction after cpsid i to the unmasking one, inclusive, at zero "
                                      "wait states; fetches: 32-bit flash fetches on that path (add one cycle per "
                                      "fetch and wait state).",
                             "sections": [], "worst": {}}
    for device, elf, source in IMAGES:
        found = sections(disassemble(elf), device, source)
        table["sections"].extend(found)
        table["worst"][device] = found[0]["id"]
    return table


def cycles(table: dict[str, Any], section: str, flash_ws: float) -> float:
    """Cycles of `section` (an id of the table) with `flash_ws` wait states."""
    for s in table["sections"]:
        if s["id"] == section:
            return float(s["cycles"]) + flash_ws * float(s["fetches"])
    raise KeyError(section)


def load() -> dict[str, Any]:
    """The committed table."""
    return dict(json.loads(TABLE.read_text(encoding="utf-8")))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description="PRIMASK critical sections of the Cortex-M0+ images")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true", help=f"write {TABLE.relative_to(REPO)}")
    mode.add_argument("--check", action="store_true", help="fail when the committed table is stale")
    args = ap.parse_args(argv)
    try:
        table = measure()
    except CriticalError as exc:
        print(f"urb_sim.critical: {exc}", file=sys.stderr)
        return 2
    text = json.dumps(table, indent=1) + "\n"
    if args.write:
        TABLE.write_text(text, encoding="utf-8")
        print(f"wrote {TABLE.relative_to(REPO)}")
    elif args.check:
        committed = TABLE.read_text(encoding="utf-8") if TABLE.exists() else ""
        if committed != text:
            print(f"{TABLE.relative_to(REPO)} is stale: the firmware's critical sections changed. Measured:\n{text}"
                  "Run `python3 -m urb_sim.critical --write`, then review the hardware profiles that use it "
                  "(sim/profiles/*.toml).", file=sys.stderr)
            return 1
        print(f"critical sections: {TABLE.relative_to(REPO)} matches the images "
              + ", ".join(f"(worst {d}: {table['worst'][d]})" for d in table["worst"]))
    else:
        for s in table["sections"]:
            print(f"{s['id']:<32} {s['cycles']:>4} cycles  {s['fetches']:>3} fetches  {s['instructions']:>3} instructions")
    return 0


if __name__ == "__main__":
    sys.exit(main())
