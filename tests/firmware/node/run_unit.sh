#!/usr/bin/env bash
# Runs the node unit-test programs (make fwn-unit). gcc builds print cmocka's standard report;
# clang builds write JUnit XML to <build>/junit/ for CI evidence and print one line each (the
# full report when one fails). Exit status: 1 if any program failed.
set -u
build=$1
shift
mkdir -p "$build/junit"
status=0
for bin in "$@"; do
    cc=$(basename "$(dirname "$bin")")
    name=$(basename "$bin")
    if [ "$cc" = gcc ]; then
        echo "== $cc $name"
        "$bin" || status=1
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
    fi
done
exit $status
