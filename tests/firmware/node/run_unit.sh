#!/usr/bin/env bash
# Runs the node unit-test programs (make fwn-unit). gcc builds print cmocka's standard report (kept
# in <build>/junit/gcc-<program>.log too); clang builds write JUnit XML to <build>/junit/ and print
# one line each (the full report when one fails). Then both are written as one evidence record,
# build/evidence/cmocka-node.json (report/urb_report/junit.py), whether the tests passed or not.
# Exit status: 1 if any program failed or the record could not be written.
set -u
build=$1
shift
mkdir -p "$build/junit"
status=0
record_args=()
for bin in "$@"; do
    cc=$(basename "$(dirname "$bin")")
    name=$(basename "$bin")
    if [ "$cc" = gcc ]; then
        log="$build/junit/$cc-$name.log"
        echo "== $cc $name"
        "$bin" 2>&1 | tee "$log"
        [ "${PIPESTATUS[0]}" -eq 0 ] || status=1
        record_args+=(--log "$cc:$name=$log")
    else
        xml="$build/junit/$cc-$name.xml"
        err="$build/junit/$cc-$name.log"
        rm -f "$xml"
        if CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE="$xml" "$bin" >"$err" 2>&1; then
            echo "== $cc $name: passed, $(grep -o 'tests="[0-9]*"' "$xml" | head -1 | tr -dc 0-9) tests (JUnit: $xml)"
        else
            echo "== $cc $name: FAILED"
            cat "$err" "$xml" 2>/dev/null
            status=1
        fi
        record_args+=(--xml "$cc:$name=$xml")
    fi
done
${PYTHON:-python3} -m urb_report.junit cmocka --name cmocka-node "${record_args[@]}" \
    --rerun "make fwn-unit  # then run build/firmware/node/<compiler>/<program>" \
    --tool "gcc=$(gcc --version | head -1)" --tool "clang=$(clang --version | head -1)" || status=1
exit $status
