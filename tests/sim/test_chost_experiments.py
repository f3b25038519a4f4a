"""Table I, the fault scenarios and the bridge and mailbox traces on the C host library (sim/world/sim_host_plain.c, urb_sim.chost),
each agreeing with the Python host library's run of the same seed (`urb sim sensorhex --host c`).

Each has its own seeded bug of the C host, built into its own library (URBSIM_MUTANT), which the
experiment's own agreement criterion must reject: a period's plain requests going out last added
first (CHOST_PLAIN_REVERSED: Table I reads node B before node A, the bridge traces change) and a lost response recorded
without its UPLINK_TIMEOUT flag (CHOST_LOSE_UPLINK_TIMEOUT: the bridge-reset scenario's requests
in flight look successful)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from urb_sim.chost import Request
from urb_sim.experiments import faults, sync, traces

T1_MS = 300  #: Table I run length of the mutant comparison: the reads start after 40 ms of settling


def test_table1_on_the_c_host(tmp_path: Path) -> None:
    res = sync.table1(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    [agree] = [c for c in res.checks if c.name == "host libraries agree"]
    assert agree.passed and agree.measured.endswith("reads: equal")
    assert int(agree.measured.split()[0]) > 1000  # witness: the compared run read both nodes every ms
    assert "(on the C host library)" in res.title


def test_fault_scenarios_on_the_c_host(tmp_path: Path) -> None:
    """Every scenario on the C host: the same checks pass, and each agrees with its Python run
    (requests, flags, bridge status, data, callback order and instants, reaction, fault trace)."""
    res = faults.faults(tmp_path, quick=True, host="c")
    assert res.passed, [(c.name, c.measured) for c in res.checks if not c.passed]
    agree = [c for c in res.checks if c.name.endswith("host libraries agree")]
    assert len(agree) == len(faults.scenarios()) and all(c.measured.endswith("requests: equal") for c in agree)
    assert not list(tmp_path.glob("trace_*.python.ndjson"))  # the reference runs' traces are not kept
    flags = {row["scenario"]: row["flags"] for row in res.table}
    # witnesses: the faults the host library itself reports were exercised on the C host
    assert "UPLINK_TIMEOUT" in flags["bridge_reset"] and "UPLINK_CHECKSUM" in flags["uart_bit_errors"]
    assert "BUS_STUCK" in flags["i2c_scl_stuck"] and "NO_NODE" in flags["node_power_loss"]


def agreement_in_a_new_process(mutant: str, experiment: str) -> tuple[bool, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("URBSIM_MUTANT", "URBSIM_SANITIZE")}
    env["URBSIM_MUTANT"] = mutant
    proc = subprocess.run([sys.executable, __file__, experiment], capture_output=True, text=True, env=env,
                          timeout=600, cwd=Path(__file__).resolve().parents[2])
    assert proc.returncode == 0, proc.stderr
    passed, measured = json.loads(proc.stdout)
    return bool(passed), str(measured)


def test_table1_agreement_rejects_reversed_plain_requests() -> None:
    passed, measured = agreement_in_a_new_process("CHOST_PLAIN_REVERSED", "table1")
    assert not passed
    assert "read 0: Python Request(bridge=0, address=16" in measured and "C Request(bridge=0, address=17" in measured


def test_faults_agreement_rejects_a_lost_uplink_timeout_flag() -> None:
    passed, measured = agreement_in_a_new_process("CHOST_LOSE_UPLINK_TIMEOUT", "faults")
    assert not passed
    assert "failures: Python Counter({'UPLINK_TIMEOUT': " in measured and "C Counter()" in measured


def test_traces_agreement_rejects_reversed_plain_requests() -> None:
    """The bridge traces recorded on the C host differ where a period's reads and write go out in
    another order (the mailbox traces, one request a period, are the same)."""
    passed, measured = agreement_in_a_new_process("CHOST_PLAIN_REVERSED", "traces")
    assert not passed
    assert measured == "5 traces: differ: trace_rs232.ndjson, trace_usb.ndjson, trace_usb_ber.ndjson"


def _mutant_agreement(experiment: str, out: Path) -> tuple[str, str, str, bool]:
    """The experiment's agreement check of one run on the C host library (built as URBSIM_MUTANT says)."""
    if experiment == "traces":
        cycles = 40
        for uplink, seed, ber in (("rs232", 400, 0.0), ("usb", 401, 0.0), ("usb", 409, traces.BER)):
            traces.record(uplink, seed, cycles, out, ber=ber, host="c")
        traces.record_outbox(405, traces.outbox_cycles(cycles), out, host="c")
        traces.record_inbox(406, traces.INBOX_WRITES, out, host="c")
        return traces.host_agreement("c", 400, cycles, out)
    if experiment == "table1":
        record: list[Request] = []
        kept = sync.one_run(100, True, T1_MS, host="c", record=record)
        return sync.agreement(kept, record, T1_MS, "c")
    i, sc = next((i, sc) for i, sc in enumerate(faults.scenarios()) if sc.key == "bridge_reset")
    return faults.agreement(sc, faults.run_scenario(sc, 300 + i, host="c"), 300 + i, "c", out)


if __name__ == "__main__":
    import tempfile

    with tempfile.TemporaryDirectory() as folder:
        _, _, measured_, passed_ = _mutant_agreement(sys.argv[1], Path(folder))
    print(json.dumps([passed_, measured_]))
