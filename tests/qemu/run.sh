#!/usr/bin/env bash
# Runs the Cortex-M0 test program on QEMU, always under a timeout (see tests/qemu/README.md).
#
#   tests/qemu/run.sh [--machine M] [--expect pass|fail|hardfault] [--quiet] [--name TEXT] ELF [GROUP...]
#
# GROUP: vectors, node (none: both); passed to the program with -append. Without --expect the
# program's report is printed and QEMU's exit status is returned (0 pass, 1 a check failed,
# 2 unknown group, 3 HardFault, 4 other exception, 124 timeout). With --expect the run must end
# that way: `pass` (status 0, no "not ok"), `fail` (status 1 with a "not ok" line) or `hardfault`
# (status 3 with the handler's report); then only the evidence is printed and the status is 0 when
# the expectation holds, 1 otherwise (--quiet: only the verdict unless it does not). A timeout or a QEMU error never meets an expectation.
# Environment: QEMU_TIMEOUT (seconds, default 20), QEMU_SYSTEM_ARM, CROSS_ADDR2LINE.
set -u

machine=microbit
expect=""
name=""
quiet=0
while [[ $# -gt 0 ]]; do
  case "$1" in
    --machine) machine="$2"; shift 2 ;;
    --expect) expect="$2"; shift 2 ;;
    --name) name="$2"; shift 2 ;;
    --quiet) quiet=1; shift ;;
    -*) echo "run.sh: unknown option $1" >&2; exit 2 ;;
    *) break ;;
  esac
done
if [[ $# -lt 1 ]]; then
  echo "usage: tests/qemu/run.sh [--machine M] [--expect pass|fail|hardfault] [--quiet] [--name TEXT] ELF [GROUP...]" >&2
  exit 2
fi
elf="$1"; shift
name="${name:-$(basename "$elf" .elf)}"
qemu="${QEMU_SYSTEM_ARM:-qemu-system-arm}"
addr2line="${CROSS_ADDR2LINE:-arm-none-eabi-addr2line}"
limit="${QEMU_TIMEOUT:-20}"
log="${elf%.elf}${machine:+.$machine}.log"

start=$(date +%s%N)
# stdin from /dev/null: -nographic would otherwise put a terminal into raw mode for its monitor
timeout -k 5 "$limit" "$qemu" -M "$machine" -nographic -monitor none -serial null \
  -semihosting-config enable=on,target=native -kernel "$elf" ${1:+-append "$*"} </dev/null >"$log" 2>&1
rc=$?
ms=$(( ($(date +%s%N) - start) / 1000000 ))
secs=$(printf '%d.%03d' $((ms / 1000)) $((ms % 1000)))

# A HardFault report names pc: add the function and source line.
fault_pc=$(sed -n 's/^HardFault: pc=\(0x[0-9a-f]*\).*/\1/p' "$log" | head -n 1)
where=""
if [[ -n "$fault_pc" ]] && command -v "$addr2line" >/dev/null; then
  where=$("$addr2line" -f -p -e "$elf" "$fault_pc" 2>/dev/null | sed "s|$(pwd)/||")
  echo "#   pc $fault_pc is in $where" >>"$log"
fi
summary=$(grep -m 1 '^# [0-9]* checks, [0-9]* failed' "$log" | sed 's/^# //')

outcome="status $rc"
case $rc in
  0) outcome="passed" ;;
  1) outcome="a check failed" ;;
  3) outcome="HardFault" ;;
  124|137) outcome="TIMEOUT after ${limit} s (hung)" ;;
esac

if [[ -z "$expect" ]]; then
  cat "$log"
  echo "run.sh: $name on $machine: $outcome${summary:+, $summary} ($secs s)"
  exit $rc
fi

met=0
case "$expect" in
  pass) [[ $rc -eq 0 ]] && ! grep -q '^not ok' "$log" && [[ -n "$summary" ]] && met=1 ;;
  fail) [[ $rc -eq 1 ]] && grep -q '^not ok' "$log" && met=1 ;;
  hardfault) [[ $rc -eq 3 ]] && grep -q '^HardFault: pc=' "$log" && met=1 ;;
  *) echo "run.sh: --expect pass, fail or hardfault" >&2; exit 2 ;;
esac

if [[ $met -eq 1 && $quiet -eq 1 ]]; then
  :
elif [[ "$expect" == pass && $met -eq 1 ]]; then
  cat "$log"
elif [[ $met -eq 1 ]]; then
  grep -E '^(# URB|not ok|#   |HardFault)' "$log" | sed 's/^/  /'
else
  cat "$log"
fi
if [[ $met -eq 1 ]]; then
  echo "qemu: $name on $machine: $outcome as expected${summary:+ ($summary)}, $secs s"
  exit 0
fi
echo "qemu: $name on $machine: $outcome${summary:+ ($summary)}, but it must end '$expect' (log: $log), $secs s"
exit 1
