#!/usr/bin/env python3
"""Worst-case cost of the node's interrupt handlers (make wcet-node).

1. Runs tests/firmware/node/wcet_driver under valgrind --tool=callgrind, collecting only inside the
   `wcet_*` wrappers (each makes exactly one handler call in its worst state), and reports each
   wrapper's inclusive instruction count (x86-64, gcc -O2: a relative measure; the handler plus the
   hosted HAL calls it makes).
2. Lists every loop of the node library (firmware/node/*.c) and of the generated runtime
   (gen/c/urb_runtime.c) with its enclosing function and its static bound, and marks the functions
   an interrupt handler executed. A library loop without a `bound:` comment fails the run.

Writes a Markdown report (--out) and prints it. With --readme FILE it also fails when the handler
table in FILE (firmware/node/README.md, copied from this report) differs from the measurement, so
the documented numbers cannot drift from the code (`make wcet-node-check`, part of `make check`).
"""
from __future__ import annotations

import argparse
import difflib
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]

SCENARIOS = {
    "wcet_i2c_restart_commits": ("I2C", "ADDR_WRITE", "repeated START after a complete CRC-16 write: IsrWriteCommit, then a new select"),
    "wcet_i2c_stop_commits": ("I2C", "STOP", "STOP after a complete CRC-16 write: IsrWriteCommit"),
    "wcet_i2c_rx_select": ("I2C", "RX_BYTE", "select byte of a 20-byte inbox: CRC-16 start"),
    "wcet_i2c_rx_first_data": ("I2C", "RX_BYTE", "first data byte: IsrWriteBegin + IsrWriteByte + CRC-16 byte"),
    "wcet_i2c_rx_refused": ("I2C", "RX_BYTE", "first data byte refused (both buffers in use): OVERRUN + NACK"),
    "wcet_i2c_rx_last_check_bad": ("I2C", "RX_BYTE", "last CRC-16 check byte fails: IsrWriteAbort + CHECKSUM + NACK"),
    "wcet_i2c_rx_last_check_ok": ("I2C", "RX_BYTE", "last CRC-16 check byte passes"),
    "wcet_i2c_rx_extra_byte": ("I2C", "RX_BYTE", "byte beyond size + check: IsrWriteAbort + NACK"),
    "wcet_i2c_addr_read_ends_read": ("I2C", "ADDR_READ", "ends a complete outbox-0 read, IsrReadBegin, CRC-16 of the select"),
    "wcet_i2c_tx_data": ("I2C", "TX_BYTE", "data byte: IsrReadByte + CRC-16 byte"),
    "wcet_i2c_tx_check": ("I2C", "TX_BYTE", "CRC-16 check byte"),
    "wcet_i2c_tx_nack": ("I2C", "TX_NACK", "end of a complete outbox-0 read: IsrReadEnd"),
    "wcet_i2c_rx_in_read": ("I2C", "RX_BYTE", "byte received during a complete outbox-0 read: IsrReadEnd + NACK"),
    "wcet_i2c_general_call": ("I2C", "GENERAL_CALL", "SYNC time stamp (HAL capture) + mark"),
    "wcet_i2c_sync_counter_track": ("I2C", "RX_BYTE", "SYNC counter, tracking, 2 SYNCs missed: eq. 1 (one division) + eq. 2"),
    "wcet_i2c_sync_counter_acquire": ("I2C", "RX_BYTE", "SYNC counter, acquisition: phase jump"),
    "wcet_i2c_stuck": ("I2C", "STUCK", "stuck bus in a write: IsrWriteAbort + STUCK_BUS"),
    "wcet_timer_beat": ("timer", "compare", "heartbeat: schedule the next, update due"),
    "wcet_timer_request": ("timer", "compare", "heartbeat applying a SYNC_CONFIG request"),
    "wcet_timer_lost_sync": ("timer", "compare", "heartbeat declaring LOST_SYNC"),
}

LINE = re.compile(r"^\s*([\d,]+)\s+\(\s*[\d.]+%\)\s+(\*\s+)?(\S+?):(\S+)")
LOOP = re.compile(r"\b(for|while)\s*\(")


def callgrind(driver: Path) -> tuple[dict[str, int], set[str]]:
    for tool in ("valgrind", "callgrind_annotate"):
        if shutil.which(tool) is None:
            sys.exit(f"wcet: {tool} not found (apt-get install valgrind)")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", "--toggle-collect=wcet_*",
                        str(driver)], check=True, capture_output=True)
        incl = subprocess.run(["callgrind_annotate", "--inclusive=yes", "--threshold=100", str(out)], check=True,
                              capture_output=True, text=True).stdout
        self_ = subprocess.run(["callgrind_annotate", "--inclusive=no", "--threshold=100", str(out)], check=True,
                               capture_output=True, text=True).stdout
    wrappers: dict[str, int] = {}
    for line in incl.splitlines():
        m = LINE.match(line)
        if m and m.group(4) in SCENARIOS:
            wrappers[m.group(4)] = int(m.group(1).replace(",", ""))
    executed = set()
    for line in self_.splitlines():
        m = LINE.match(line)
        if m and int(m.group(1).replace(",", "")) > 0:
            executed.add(m.group(4))
    return wrappers, executed


def loops(files: list[Path]) -> list[tuple[str, int, str, str]]:
    rows = []
    for f in files:
        text = f.read_text().splitlines()
        func = "?"
        for i, line in enumerate(text):
            if line.startswith("{"):  # a function body: its name is the last `name(` of the signature
                head = " ".join(t for t in text[max(0, i - 3):i] if not t.lstrip().startswith(("/*", "*")))
                names = re.findall(r"([A-Za-z_]\w*)\s*\(", head.split(";")[-1].split("}")[-1])
                if names:
                    func = names[0]
            if LOOP.search(line) and not line.lstrip().startswith(("/*", "*", "//")):
                window = " ".join(text[max(0, i - 4):i + 1])
                bound = re.search(r"bound:\s*(.+?)\s*\*/", window)
                variant = re.search(r"loop variant ([^;*]+)", window)
                if bound:
                    text_bound = bound.group(1)
                elif variant:
                    text_bound = f"ACSL variant {variant.group(1).strip()}"
                else:
                    text_bound = ""
                rows.append((f"{f.relative_to(ROOT)}:{i + 1}", 0, func, text_bound))
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--driver", type=Path, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--readme", type=Path, help="fail when this file's handler table differs from the measurement")
    ap.add_argument("--quiet", action="store_true", help="do not print the report (it is still written to --out)")
    args = ap.parse_args()
    wrappers, executed = callgrind(args.driver)
    missing = sorted(set(SCENARIOS) - set(wrappers))
    out = ["# Node interrupt handlers: worst-case instruction counts and loop bounds", "",
           "Generated by `make wcet-node` (tests/firmware/node/wcet.py); do not edit by hand.", "",
           "| handler | event | worst-case scenario | instructions |", "|---|---|---|---:|"]
    worst: dict[str, int] = {}
    for name, (handler, event, what) in SCENARIOS.items():
        n = wrappers.get(name)
        out.append(f"| {handler} | {event} | {what} | {n if n is not None else 'missing'} |")
        if n is not None:
            worst[handler] = max(worst.get(handler, 0), n)
    out.append("")
    out.append("Worst per handler: " + ", ".join(f"{h} {n} instructions" for h, n in worst.items()) +
               " (x86-64, gcc -O2, callgrind Ir, hosted HAL calls included).")
    out += ["", "| loop | function | static bound | run by an interrupt handler |", "|---|---|---|---|"]
    status = 0 if not missing else 1
    files = sorted((ROOT / "firmware/node").glob("*.c")) + [ROOT / "gen/c/urb_runtime.c"]
    for where, _, func, bound in loops(files):
        in_isr = "yes" if func in executed else "no"
        if not bound:
            bound = "**none**"
            if where.startswith("firmware/node/"):
                status = 1
        out.append(f"| {where} | {func} | {bound} | {in_isr} |")
    out.append("")
    isr_loops = [row for row in loops(files) if row[2] in executed]
    out.append("Functions the interrupt handlers executed (self cost > 0): " +
               ", ".join(sorted(f for f in executed if not f.startswith("wcet_"))) + ".")
    out.append("")
    out.append(f"Loops on an interrupt path: {len(isr_loops)} (0: every handler is straight-line code, O(1), "
               "a CRC byte update included).")
    report = "\n".join(out) + "\n"
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(report)
    if not args.quiet:
        print(report)
    if missing:
        print(f"wcet: scenarios without a measurement: {', '.join(missing)}", file=sys.stderr)
    if args.readme is not None and not readme_agrees(args.readme, out, args.out):
        status = 1
    return status


def handler_rows(lines: list[str]) -> list[str]:
    """The rows of the handler table (4 cells, the first I2C or timer), whitespace-normalised."""
    rows = []
    for line in lines:
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) == 4 and cells[0] in ("I2C", "timer"):
            rows.append(" | ".join(cells))
    return rows


def readme_agrees(readme: Path, report: list[str], out: Path) -> bool:
    """True when `readme` holds exactly the measured handler table; prints the differences. The
    check must be able to fail: the same README with one count changed must be refused."""
    text = readme.read_text().splitlines()
    documented = handler_rows(text)
    measured = handler_rows(report)
    first = next((i for i, line in enumerate(text) if handler_rows([line])), None)
    if first is None:
        print(f"wcet: no handler table in {readme}", file=sys.stderr)
        return False
    cells = text[first].rstrip().rstrip("|").rsplit("|", 1)
    seeded = text[:first] + [f"{cells[0]}| {int(cells[1]) + 1} |"] + text[first + 1:]
    if handler_rows(seeded) == measured:
        print("wcet: the README check cannot fail: a changed count was accepted", file=sys.stderr)
        return False
    if documented == measured:
        print(f"wcet: {readme} agrees with the measurement ({len(measured)} rows; a changed count is refused)")
        return True
    print(f"wcet: the handler table in {readme} differs from the measurement; copy the table of {out} into it "
          "(after checking that the change is intended):", file=sys.stderr)
    for line in difflib.unified_diff(documented, measured, "documented", "measured", lineterm="", n=0):
        print(f"  {line}", file=sys.stderr)
    return False

if __name__ == "__main__":
    sys.exit(main())
