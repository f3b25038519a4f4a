#!/usr/bin/env bash
# Mutant check (make fwn-mutants): each URB_MUTANT_* flag seeds one bug in the node library;
# the unit tests must FAIL for every one of them, and pass without any (the control), which
# shows the tests can fail and that the failures come from the seeded bug.
#
#   SINGLE_BUFFER           both sides use the published buffer (MailboxOutbox/Inbox_SingleBuffer)
#   OUTBOX_NO_BUSY_CHECK    AppLockCheck skipped (MailboxOutbox_NoBusyCheck)
#   INBOX_NO_FRONT_RECHECK  AppLockCheckFront skipped (MailboxInbox_NoFrontRecheck)
#   INBOX_NO_NACK           IsrWriteBegin never refuses (MailboxInbox_NoNack)
#   COMMIT_BAD_CHECK        a write with a failed check is committed
#   READ_CHECK_NO_SELECT    the read check leaves out the implicit select byte
#   READ_KEPT_ON_RX         a byte received during a read refuses it without ending it
#   PLL_NO_PHASE            K_n = 0: the heartbeat locks its period but not its phase
#   NO_LOST_SYNC            a lost SYNC is never declared
#   ACQ_NO_DECAY            the t_acq window never completes: an inflated sample is kept for good
#
# Builds without sanitizers (speed); objects that no mutant touches are compiled once.
set -u
out=${1:-build/firmware/node/mutants}
cd "$(dirname "$0")/../../.."
CC=${CC:-gcc}
CFLAGS="-std=c99 -O1 -g -w -DURB_NODE_TESTING"
INC="-Ifirmware/include -Ifirmware/node -Ifirmware/hal/hosted -Ifirmware/apps/sensorhex -Igen/c -Itests/firmware/node -Itests/firmware/pll"
LIB="firmware/node/urb_mailbox.c firmware/node/urb_i2c.c firmware/node/urb_pll.c firmware/node/urb_node.c firmware/node/urb_observe.c"
COMMON="tests/firmware/node/node_fixture.c gen/c/urb_runtime.c gen/c/urb_core.c gen/c/urb_sensorhex.c firmware/hal/hosted/urb_hal_hosted.c"
TESTS="test_mailbox test_i2c test_node test_interleave test_pll test_apps test_single"
MUTANTS="SINGLE_BUFFER OUTBOX_NO_BUSY_CHECK INBOX_NO_FRONT_RECHECK INBOX_NO_NACK COMMIT_BAD_CHECK READ_CHECK_NO_SELECT READ_KEPT_ON_RX PLL_NO_PHASE NO_LOST_SYNC ACQ_NO_DECAY"

extra() {
    case $1 in
    test_pll) echo tests/firmware/pll/pll_model.c ;;
    test_apps) echo firmware/apps/sensorhex/sensorhex_motor.c firmware/apps/sensorhex/sensorhex_battery.c \
        firmware/apps/sensorhex/sensorhex_imu.c firmware/apps/sensorhex/sensorhex_ir.c ;;
    test_single) echo firmware/node/urb_single.c ;;
    esac
}

obj() { # source, directory -> object path
    echo "$2/$(echo "$1" | tr / _ | sed 's/\.c$/.o/')"
}

mkdir -p "$out/common"
# A shared object is stale when its source or any header is newer (urb_node_t's layout lives in a header).
newest_header=$(ls -t firmware/include/*.h firmware/node/*.h firmware/hal/hosted/*.h tests/firmware/node/*.h \
                tests/firmware/pll/*.h gen/c/*.h | head -1)
for t in $TESTS; do
    for src in tests/firmware/node/$t.c $COMMON $(extra "$t"); do
        o=$(obj "$src" "$out/common")
        if [ ! -f "$o" ] || [ "$src" -nt "$o" ] || [ "$newest_header" -nt "$o" ]; then
            $CC $CFLAGS $INC -c "$src" -o "$o" || exit 2
        fi
    done
done

# Builds the library with flag $1 (or none), links and runs every test program; prints the
# names of the failing programs.
run_variant() {
    local name=$1 flag=$2 dir="$out/$1" failed=""
    mkdir -p "$dir"
    for src in $LIB; do
        $CC $CFLAGS $flag $INC -c "$src" -o "$(obj "$src" "$dir")" || return 2
    done
    for t in $TESTS; do
        local objs=""
        for src in tests/firmware/node/$t.c $COMMON $(extra "$t"); do objs="$objs $(obj "$src" "$out/common")"; done
        for src in $LIB; do objs="$objs $(obj "$src" "$dir")"; done
        $CC -o "$dir/$t" $objs -lcmocka -lm || return 2
        if ! timeout 120 "$dir/$t" >"$dir/$t.log" 2>&1; then
            failed="$failed $t"
        fi
    done
    echo "$failed"
}

status=0
control=$(run_variant control "")
if [ -n "$control" ]; then
    echo "mutants: the control build (no mutant) fails:$control"
    exit 1
fi
printf '%-26s %s\n' "mutant" "killed by (test programs that fail)"
for m in $MUTANTS; do
    failed=$(run_variant "$m" "-DURB_MUTANT_$m")
    if [ -z "$failed" ]; then
        printf '%-26s %s\n' "$m" "SURVIVED: no test fails"
        status=1
    else
        printf '%-26s %s\n' "$m" "killed:$failed"
    fi
done
[ $status -eq 0 ] && echo "mutants: all $(echo $MUTANTS | wc -w) killed, control passes"
exit $status
