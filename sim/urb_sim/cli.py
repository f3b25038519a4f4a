"""`urb sim`: the time-accurate simulation of the SensoRHex buses (sim/README.md).

Registered by host/urb/cli.py; everything else lives in the urb_sim package.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

from .build import REPO, BuildError, check_loadable, ensure_library
from .experiments import SEED_SPAN, Progress
from .runner import DOWNLINK_EXPERIMENTS, EXPERIMENTS, available_cpus, run_experiments, select

#: `urb sim` subcommands and their one-line summaries (listed in `urb sim --help`).
SUBCOMMANDS = {"sensorhex": "run the scenario and the paper's experiments, write the HTML report",
               "sweep": "run the experiments over many seeds: which criteria fail, and where",
               "merge": "merge the shard files of a sweep run as --shard K/N pieces",
               "sensitivity": "Table I, latency and loop lag as functions of the hardware",
               "profiles": "list the hardware profiles and their model assumptions",
               "params": "list the model parameters, their defaults and meaning"}

SIM_EXIT_STATUS = """\
Exit status (each subcommand's --help says what counts as a failure there):
  0    success: every acceptance criterion met, every point measured, every profile valid
  1    a criterion not met, or an experiment or run that ended in ERROR
  2    a usage error (an unknown experiment, profile or option, a value out of range, an output
       folder that cannot be written) or a simulation library that cannot be built
  130  interrupted by Ctrl-C"""

SENSORHEX_HELP = """\
Run the SensoRHex simulation and the paper's experiments, and write an HTML summary.

The real node library, SensoRHex applications and bridge firmware (compiled for this computer)
run on simulated microcontrollers and buses: I2C at 400 kb/s, RS232 at 115200 Bd, USB with 1-ms
frames, crystals with frequency error and drift. The host library runs unchanged on a simulated
CPU whose threads wake on the 1-kHz OS tick. Each experiment writes CSV files and (all but
traces, can and rs485) PNG figures, and states PASS or FAIL against its acceptance criterion:

  fig15    round-trip latency of 1000 reads at 1 kHz over RS232 + I2C, payload 1..10 bytes
  fig16    the same over USB + I2C, payload 1..31 bytes
  table1   synchronisation of two nodes on one downlink, 20 seeds, with the unsynchronised
           baseline of Fig. 11
  fig18_19 PD position control of a hip motor at 1 kHz over RS232 and over USB: the
           motor driver node runs on a DC motor, gearhead and leg model
  fig20    the SensoRHex system of Fig. 14 (two USB bridges with three motor nodes each, an
           RS232 bridge with battery, IMU and IR nodes) walking an alternating tripod gait
  bandwidth the highest read rate and payload each uplink sustains without missed deadlines,
           and how many motors per USB bridge a 1-kHz or 500-Hz loop can serve
  faults   every fault the design must survive (bit errors, stuck I2C lines, node power loss,
           bridge reset, babbling node, uplink byte loss): each failed request must reach its
           callback with the right error flag, and the firmware's reaction is logged
  traces   TLC checks traces logged by the simulation against every module of spec/tla:
           bridge (Bridge.tla), outbox and inbox (MailboxOutbox.tla, MailboxInbox.tla), the
           host's USB frames (UsbUplink.tla) and its discovery (Discovery.tla)
  can      SensoRHex with the motor nodes on CAN (1 Mb/s; latency also at 500 and 250 kb/s)
           and the slow sensors on RS485 (115200 Bd): read latency, SYNC time stamps, the PD
           loop on the motor cycle, a node driven to bus-off and back, the sensors' poll
  rs485    the same with every node on RS485 (motors at 1 Mb/s, sensors at 115200 Bd),
           character errors and a stalled answer in place of bus-off

Downlinks (--downlink; the experiments run when --only is not given):
  i2c      the paper's I2C downlinks: fig15 .. traces (the default, as before)
  can      motors on CAN, sensors on RS485: the experiment can
  rs485    every node on RS485: the experiment rs485
  all      every experiment above
CAN and RS485 are bit-timed bus models (to the bit, with stuffing of each frame's actual bits,
arbitration, error frames, error counters, bus-off and recovery; RS485 to the character, with
driver turnaround and the t3.5 / t1.5 silences) on which the bridges' masters and the nodes'
slaves of firmware/downlink run (loaded through ctypes; the node library's mailboxes are a
table until it can choose these downlinks). Their criteria are derived from the bus timing, and their report
holds one table with I2C, CAN and RS485 side by side (latency, SYNC inter-node difference,
motor cycle, control) and the model's assumptions (sim/README.md, "Downlinks").

Output: DIR/index.html (open it first), DIR/summary.json, and one folder per experiment.
The same seed gives the same numbers, byte for byte. The report's headline names every
acceptance criterion that is not met and every result that does not reproduce the paper; the
page ends with the run's provenance (commit, clean tree or not, date, machine, seed, compiler
and flags of the simulation library, Python).

Hardware profiles (sim/profiles, `urb sim profiles`): the model's inputs as data, each value with
its source. Every experiment runs under --profile (default cortex-m0plus, the Cortex-M0+ at 48 MHz
the firmware targets); table1, fig15 and fig16 also run under each --compare profile (default:
all the others: the idealised model, and one calibrated to the paper's Table I), and the report
shows each profile's Table I and latency figures beside its assumptions. --sensitivity adds the
sensitivity study (`urb sim sensitivity --help`) to the same run and report.

Evidence: one record per experiment, EVIDENCE/sim-<experiment>.json (default build/evidence),
one item per acceptance criterion (sim:<experiment>/<criterion>; under another profile than the
default sim-<experiment>@<profile>.json and sim@<profile>:<experiment>/<criterion>) with its verdict, required and
measured value, source file and the command that runs it again (report/urb_report/records.py).
A build with a seeded bug (URBSIM_MUTANT) writes none.

Each experiment ends PASS, FAIL (a criterion is not met) or ERROR (it raised, or its worker
process died: DIR/<key>/error.txt says why); an ERROR does not stop the others.

Exit status: 0 when every acceptance criterion is met, 1 when one is not or an experiment
ended in ERROR, 2 on a usage or build error (the message says what to do), 130 on Ctrl-C."""


SWEEP_HELP = f"""\
Run the paper's experiments (see `urb sim sensorhex --help`) at many seeds, several at once,
and tell how often each acceptance criterion holds and at which seeds it fails.

A seed fixes everything the simulation draws: crystal errors and drifts, interrupt latencies,
the host's phase against the nodes and the USB frames, fault instants. One report shows one
sample; a sweep shows whether a PASS is typical. Every failed run is listed with the command
that runs it again alone, with its full report:

  urb sim sensorhex --seed N --only EXPERIMENT [--quick]

Output in DIR: checks.csv (per seed, experiment and check: required, measured, passed),
runs.csv (per seed and experiment: verdict, simulated and wall seconds), summary.json (per
check: runs, failures, failing seeds), and runs/seed-N/EXPERIMENT/ with the CSV and PNG files of
each run that did not pass (of every run with --keep). DIR/runs/ is emptied first.

An experiment at seed s also builds worlds at seeds s+1 .. s+{SEED_SPAN - 1} (table1's 20 runs, one
per fault scenario, the trace recordings), so runs at neighbouring seeds share worlds: for
independent samples take seeds {SEED_SPAN} apart (--seeds 0-{99 * SEED_SPAN}/{SEED_SPAN}: 100 seeds); the sweep
says so when they are closer.

Exit status: 0 when every criterion held at every seed, 1 when one did not or a run ended in
ERROR, 2 on a usage or build error, 130 on Ctrl-C.

Every run gives a record (its checks, verdict and figures); summary.json ends with the hash of
all records, which does not depend on their order nor on where they ran. Three ways to run:
  locally (default)     --jobs worker processes on this machine
  on a Dask cluster     --scheduler tcp://HOST:PORT: every run is a task on the cluster's
                        workers (`dask scheduler`, then `dask worker tcp://HOST:PORT` on each
                        machine, in this checkout's environment with its library built)
  in shards             --shard K/N runs every N-th run from the K-th and writes
                        DIR/shard-K-of-N.json; `urb sim merge DIR/shard-*.json --out DIR` checks
                        that every shard is there once and writes the whole sweep (a Slurm job
                        array: --shard $((SLURM_ARRAY_TASK_ID))/$SLURM_ARRAY_TASK_COUNT)
The same sweep gives the same hash all three ways.

Example: the synchronisation and fault experiments at 100 independent seeds, quick versions:
  urb sim sweep --seeds 0-{99 * SEED_SPAN}/{SEED_SPAN} --only table1,faults --quick"""

SENSITIVITY_HELP = """\
Table I, the latency figures (Figs. 15-16 at a 6-byte payload) and the PD loop's lag over USB as
functions of the hardware: each factor varied alone from a hardware profile (default: the
Cortex-M0+ one), so that a user can read off what their MCU and bus give, and from which value on
the node PLL stops meeting the paper's Table I. Factors (--only):

  irq_jitter  node interrupt latency jitter, 0-2 us
  timer       node heartbeat timer resolution, 48-1 MHz
  crystal     crystal frequency error of nodes and bridge, 10-3000 ppm (sd)
  bus         downlink capacitance, 50-400 pF (pull-up for a 300-ns rise time)
  heartbeat   heartbeat and SYNC rate, 1-0.1 kHz (the SYNC comes from the 1-ms USB frames)

Writes DIR/index.html with one figure per factor, DIR/sensitivity/sensitivity.csv, summary.json.
--quick: three values per factor and shorter runs (the same figures, noisier). Runs locally on
--jobs processes or on a Dask cluster (--scheduler). Exit status 0 when every point was measured,
1 when one was not, 2 on a usage or build error."""


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of 1 or more, got {text!r}")
    return value


SEED_MAX = 2**63 - 1  #: experiments add small offsets to the seed; the world takes 64 bits


def _seed(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= SEED_MAX:
        # the world keeps 64 bits of the seed: larger values would silently repeat smaller ones
        raise argparse.ArgumentTypeError(f"expected a whole number from 0 to {SEED_MAX}, got {text!r}")
    return value


def _paragraphs(*texts: str) -> str:
    """Help text of several paragraphs, each wrapped to the width of the rest of `urb --help`."""
    return "\n\n".join(textwrap.fill(t, width=100) for t in texts)


def _folder(text: str) -> Path:
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder name, got an empty one (the default is build/sim/report)")
    return Path(text)


def register(sub: Any) -> None:
    """Add `urb sim` and its subcommands to the `urb` parser."""
    sim = sub.add_parser("sim", help="the main job: simulate SensoRHex, run the paper's experiments",
                         usage="%(prog)s [-h] SUBCOMMAND ...",
                         description="Time-accurate simulation of URB buses running the real firmware.\n\n"
                                     "Subcommands:\n"
                                     + "".join(f"  {name:<11} {summary}\n" for name, summary in SUBCOMMANDS.items())
                                     + "\nRun `urb sim SUBCOMMAND --help` for its options.",
                         epilog=SIM_EXIT_STATUS, formatter_class=argparse.RawDescriptionHelpFormatter)
    # The description lists the subcommands (argparse's own list would wrap "sensorhex" onto two lines).
    # prog: without it argparse builds "urb sim [-h] SUBCOMMAND ... sensorhex" from the usage above.
    simsub = sim.add_subparsers(dest="sim_command", metavar="SUBCOMMAND", help=argparse.SUPPRESS, prog=sim.prog)
    p = simsub.add_parser("sensorhex", help=SUBCOMMANDS["sensorhex"],
                          description=SENSORHEX_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=_folder, default=REPO / "build" / "sim" / "report", metavar="DIR",
                   help="output folder (default build/sim/report)")
    p.add_argument("--seed", type=_seed, default=1, metavar="N",
                   help=f"base seed of every experiment, 0..{SEED_MAX} (default 1)")
    p.add_argument("--quick", action="store_true",
                   help="fewer payloads, reads and seeds (a few times faster); same acceptance criteria")
    p.add_argument("--only", metavar="LIST", default=None,
                   help=f"comma-separated experiments to run (default: all of {', '.join(EXPERIMENTS)})")
    cpus = available_cpus()
    p.add_argument("--jobs", type=_positive, default=cpus, metavar="N",
                   help="experiments run at once, in as many worker processes (default: the CPUs available, "
                        f"{cpus} here); the results do not depend on it")
    p.add_argument("--no-progress", action="store_true", help="no progress bar (for logs)")
    p.add_argument("--evidence", type=_folder, default=REPO / "build" / "evidence", metavar="DIR",
                   help="folder of the evidence records, sim-<experiment>.json (default build/evidence)")
    p.add_argument("--profile", default=None, metavar="NAME",
                   help="hardware profile every experiment runs under (default cortex-m0plus; `urb sim profiles`)")
    p.add_argument("--compare", default="all", metavar="LIST",
                   help="profiles table1, fig15 and fig16 also run under, comma-separated (default all: every "
                        "other profile; none: no comparison)")
    p.add_argument("--sensitivity", action="store_true",
                   help="add the sensitivity study (urb sim sensitivity) to the run and the report")
    p.add_argument("--downlink", choices=list(DOWNLINK_EXPERIMENTS), default="i2c",
                   help="which SensoRHex downlinks to simulate when --only is not given: i2c (default), can "
                        "(motors on CAN, sensors on RS485), rs485 (every node on RS485) or all")
    p.add_argument("--host", choices=["python", "c"], default="python",
                   help="the host library the loops of fig15, fig16, fig18_19, fig20 and bandwidth run on: python "
                        "(default, the reference) or c (host/c's core in the simulation, no Python in the loop: "
                        "sim/world/sim_host_c.c); either way one run of each is repeated on the other and must agree; "
                        "the other experiments run on python")
    p.set_defaults(run=run_sensorhex)
    w = simsub.add_parser("sweep", help=SUBCOMMANDS["sweep"], description=SWEEP_HELP,
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    w.add_argument("--seeds", required=True, metavar="LIST",
                   help="seeds to run: single seeds and ranges, with a step after a slash, comma-separated "
                        f"(e.g. 1-100, 0-2079/21 or 1-10,42), from 0 to {SEED_MAX}")
    w.add_argument("--only", metavar="LIST", default=None,
                   help=f"comma-separated experiments to run (default: all of {', '.join(EXPERIMENTS)})")
    w.add_argument("--quick", action="store_true", help="the quick version of each experiment (as sensorhex --quick)")
    w.add_argument("--out", type=_folder, default=REPO / "build" / "sim" / "sweep", metavar="DIR",
                   help="output folder (default build/sim/sweep)")
    w.add_argument("--jobs", type=_positive, default=cpus, metavar="N",
                   help=f"runs at once, in as many worker processes that each take one run after another "
                        f"(default: the CPUs available, {cpus} here); the results do not depend on it")
    w.add_argument("--keep", action="store_true", help="keep the files of every run, not only of those that failed")
    w.add_argument("--no-progress", action="store_true", help="no progress bar (for logs)")
    w.add_argument("--profiles", default=None, metavar="LIST",
                   help="hardware profiles to run every experiment under, comma-separated (default cortex-m0plus)")
    w.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on the Dask cluster whose scheduler is at ADDRESS (tcp://HOST:PORT) instead of local "
                        "processes")
    w.add_argument("--connect-timeout", type=_positive, default=30, metavar="S",
                   help="seconds to wait for the Dask scheduler and its first worker (default 30)")
    w.add_argument("--shard", default=None, metavar="K/N",
                   help="run only shard K of N (every N-th run from the K-th) and write DIR/shard-K-of-N.json")
    w.set_defaults(run=run_sweep_command)
    m = simsub.add_parser("merge", help=SUBCOMMANDS["merge"],
                          description=_paragraphs("Merge the shard files that `urb sim sweep --shard K/N` wrote into one sweep: "
                                      "checks that every shard of the sweep is there once, that no run is missing "
                                      "or given twice with different results, and writes checks.csv, runs.csv and "
                                      "summary.json (with the hash of all records) as a sweep run in one piece.",
                                      "Exit status: 0 when the merged sweep met every criterion at every seed, 1 when "
                                      "it did not, 2 when the shards cannot be merged (one missing or given twice, "
                                      "from another sweep, or with results that differ: the message says which) or "
                                      "the output folder cannot be written."),
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    m.add_argument("shards", nargs="+", type=Path, metavar="SHARD", help="shard files (shard-K-of-N.json)")
    m.add_argument("--out", type=_folder, default=REPO / "build" / "sim" / "sweep", metavar="DIR",
                   help="output folder (default build/sim/sweep)")
    m.set_defaults(run=run_merge)
    v = simsub.add_parser("sensitivity", help=SUBCOMMANDS["sensitivity"], description=SENSITIVITY_HELP,
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    v.add_argument("--out", type=_folder, default=REPO / "build" / "sim" / "sensitivity", metavar="DIR",
                   help="output folder (default build/sim/sensitivity)")
    v.add_argument("--seed", type=_seed, default=1, metavar="N", help="seed of every point (default 1)")
    v.add_argument("--quick", action="store_true", help="three values per factor, shorter runs")
    v.add_argument("--only", metavar="LIST", default=None, help="comma-separated factors (default: all)")
    v.add_argument("--profile", default=None, metavar="NAME", help="the profile the factors vary from "
                   "(default cortex-m0plus)")
    v.add_argument("--jobs", type=_positive, default=cpus, metavar="N", help=f"points at once (default {cpus})")
    v.add_argument("--scheduler", default=None, metavar="ADDRESS", help="run the points on a Dask cluster")
    v.add_argument("--no-progress", action="store_true", help="no progress bar (for logs)")
    v.set_defaults(run=run_sensitivity)
    r = simsub.add_parser("profiles", help=SUBCOMMANDS["profiles"],
                          description=_paragraphs("Print every hardware profile of sim/profiles with its model assumptions "
                                      "(value, source, experiments affected), validated.",
                                      "Exit status: 0 when every profile is valid, 2 when one is not (the message "
                                      "names the file and the value) or the simulation library cannot be built."),
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("--markdown", action="store_true", help="one Markdown table of every assumption (sim/README.md)")
    r.set_defaults(run=run_profiles)
    q = simsub.add_parser("params", help=SUBCOMMANDS["params"],
                          description=_paragraphs("Print every parameter of the simulation model with its default value "
                                      "and meaning (sim/world/params.h).",
                                      "Exit status: 0, or 2 when the simulation library cannot be built (the "
                                      "message says what to install or fix)."),
                          formatter_class=argparse.RawDescriptionHelpFormatter)
    q.set_defaults(run=run_params)
    sim.set_defaults(run=lambda args: (sim.print_help(), 2)[1])


def run_params(args: argparse.Namespace) -> int:
    from .native import params

    try:
        rows = params()
    except BuildError as exc:
        print(f"urb sim: {exc}", file=sys.stderr)
        return 2
    width = max(len(p.name) for p in rows)
    for p in rows:
        # whole numbers in full: %g would print an identifier such as probe.fingerprint to 6 digits
        value = f"{int(p.default)}" if float(p.default).is_integer() else f"{p.default:g}"
        print(f"{p.name:<{width}}  {value:>12}  {p.doc}")
    return 0


def _profile_names(text: str | None, *, exclude: str | None = None) -> list[str]:
    """The profiles a comma-separated list names ("all": every one but `exclude`; "none": none),
    each loaded once to validate it; raises ValueError (ProfileError) saying what is wrong."""
    from . import profiles

    if text is None:
        return [profiles.DEFAULT]
    if text.strip() == "none":
        return []
    names = ([n for n in profiles.names() if n != exclude] if text.strip() == "all"
             else [n.strip() for n in text.split(",") if n.strip()])
    if not names:
        raise ValueError(f"no profile named in {text!r}; choose from {', '.join(profiles.names())}")
    for n in names:
        profiles.load(n)
    return names


def run_profiles(args: argparse.Namespace) -> int:
    from . import profiles

    try:
        loaded = [profiles.load(n) for n in profiles.names()]
    except (profiles.ProfileError, BuildError) as exc:
        print(f"urb sim profiles: {exc}", file=sys.stderr)
        return 2
    if args.markdown:
        print(profiles.markdown(loaded))
        return 0
    for prof in loaded:
        print(f"{prof.name}{' (default)' if prof.name == profiles.DEFAULT else ''}: {prof.title}")
        for a in prof.assumptions:
            print(f"  {a.param:<28} {a.value:>10g}  {a.source}")
        for t in prof.targets:
            print(f"  target: Table I {t.metric} {t.statistic} {t.paper:g} +- {t.tolerance:g}"
                  + ("" if t.required else " (reported, not checked)"))
    return 0


def run_sensorhex(args: argparse.Namespace) -> int:
    from .profiles import PROFILE_EXPERIMENTS, ProfileError
    from .runner import task_key

    try:
        chosen = select(args.only) if args.only is not None else list(DOWNLINK_EXPERIMENTS[args.downlink])
        main_profile = _profile_names(args.profile)[0]
        compare = _profile_names(args.compare, exclude=main_profile)
        keys = [task_key(k, main_profile) for k in chosen]
        keys += [task_key(k, p) for p in compare if p != main_profile for k in chosen if k in PROFILE_EXPERIMENTS]
        if args.sensitivity:
            from . import sensitivity

            keys += [task_key(k, main_profile) for k in sensitivity.keys(None, quick=args.quick)]
    except (ValueError, ProfileError) as exc:
        print(f"urb sim sensorhex: {exc}", file=sys.stderr)
        return 2
    except BuildError as exc:
        print(f"urb sim: {exc}", file=sys.stderr)
        return 2
    if not _ready("urb sim sensorhex: cannot write the report into", args.out):
        return 2
    problem = _unwritable(args.evidence)
    if problem:
        print(f"urb sim sensorhex: cannot write the evidence records into {args.evidence}: {problem}; choose another "
              "--evidence DIR", file=sys.stderr)
        return 2
    from . import evidence
    from .report import headline, write_report

    out: Path = args.out
    os.environ["URB_SIM_HOST"] = args.host  # control.HOST_ENV, read in the worker processes too
    t0 = time.perf_counter()
    with _progress(not args.no_progress) as progress:
        results = run_experiments(keys, out, quick=args.quick, seed=args.seed, jobs=args.jobs, progress=progress)
    wall = time.perf_counter() - t0
    # stamped when written, as the records are
    from .profiles import load

    path = write_report(out, results, seed=args.seed, quick=args.quick, overrides=load(main_profile).params,
                        wall_s=wall, provenance=evidence.page_provenance(args.seed, keys))
    records = evidence.write(results, seed=args.seed, quick=args.quick, out=out, evidence_dir=args.evidence)
    for r in results:
        print(f"{r.verdict:<5} {r.key:<8} {r.title}" + ("" if "@" not in r.key else " (profile "
                                                        f"{r.key.partition('@')[2]})"))
        for c in r.checks:
            if not c.passed:
                print(f"        failed: {c.name}: required {c.required}; measured {c.measured}")
    sentence, lines = headline(results)
    print(sentence)
    for line in lines:
        print(f"  - {line}")
    sim_s = sum(r.sim_s for r in results)
    print(f"{sim_s:.1f} s simulated in {wall:.1f} s; report: {path}")
    if records:
        print(f"evidence: {len(records)} record(s) in {args.evidence} (sim-<experiment>.json)")
    else:
        print(f"evidence: none written: this build has the seeded bug URBSIM_MUTANT={evidence.mutant_build()}")
    return 0 if all(r.passed for r in results) else 1


def run_sweep_command(args: argparse.Namespace) -> int:
    from .profiles import ProfileError
    from .runner import task_key
    from .sweep import overlap_note, parse_seeds, run_sweep
    from .tasks import parse_shard

    try:
        keys = [task_key(k, p) for p in _profile_names(args.profiles) for k in select(args.only)]
        seeds = parse_seeds(args.seeds, SEED_MAX)
        shard = parse_shard(args.shard) if args.shard else None
    except (ValueError, ProfileError) as exc:
        print(f"urb sim sweep: {exc}", file=sys.stderr)
        return 2
    except BuildError as exc:
        print(f"urb sim: {exc}", file=sys.stderr)
        return 2
    if not _ready("urb sim sweep: cannot write into", args.out):
        return 2
    try:
        with _progress(not args.no_progress) as progress:
            sweep = run_sweep(keys, seeds, args.out, quick=args.quick, jobs=args.jobs, keep=args.keep,
                              progress=progress, scheduler=args.scheduler, shard=shard,
                              connect_timeout_s=args.connect_timeout)
    except RuntimeError as exc:  # the Dask scheduler cannot be reached, or Dask is missing
        print(f"urb sim sweep: {exc}", file=sys.stderr)
        return 2
    note = overlap_note(seeds)
    _print_sweep(sweep, note, args.out)
    if shard is not None:
        from .sweep import shard_path

        print(f"shard {shard[0]} of {shard[1]}: {shard_path(args.out, *shard)}; merge all of them with "
              f"`urb sim merge {args.out}/shard-*-of-{shard[1]}.json --out DIR`")
    return 0 if sweep.passed else 1


def _print_sweep(sweep: Any, note: str | None, out: Path) -> None:
    from .sweep import format_table

    for line in format_table(sweep):
        print(line)
    if note:
        print(note)
    failed = len(sweep.failed_runs())
    print(f"{len(sweep.results)} runs ({len(sweep.keys)} experiments x {len(sweep.seeds)} seeds), {failed} not "
          f"passed; {sweep.sim_s:.1f} s simulated in {sweep.wall_s:.1f} s; results: {out / 'summary.json'}")
    print(f"hash of all records: {sweep.hash}")


def run_merge(args: argparse.Namespace) -> int:
    from .sweep import merge_shards
    from .tasks import MergeError

    if _unwritable(args.out):
        print(f"urb sim merge: cannot write into {args.out}: {_unwritable(args.out)}; choose another --out DIR",
              file=sys.stderr)
        return 2
    try:
        sweep = merge_shards(args.shards, args.out)
    except MergeError as exc:
        print(f"urb sim merge: {exc}", file=sys.stderr)
        return 2
    _print_sweep(sweep, None, args.out)
    return 0 if sweep.passed else 1


def run_sensitivity(args: argparse.Namespace) -> int:
    from . import evidence, sensitivity
    from .profiles import ProfileError
    from .report import write_report
    from .runner import Task, run_tasks, task_key

    try:
        profile = _profile_names(args.profile)[0]
        only = [f.strip() for f in args.only.split(",") if f.strip()] if args.only else None
        keys = [task_key(k, profile) for k in sensitivity.keys(only, quick=args.quick)]
    except (ValueError, ProfileError) as exc:
        print(f"urb sim sensitivity: {exc}", file=sys.stderr)
        return 2
    except BuildError as exc:
        print(f"urb sim: {exc}", file=sys.stderr)
        return 2
    if not _ready("urb sim sensitivity: cannot write into", args.out):
        return 2
    out: Path = args.out
    t0 = time.perf_counter()
    try:
        with _progress(not args.no_progress) as progress:
            if args.scheduler:
                from .tasks import Spec, result_of, run_dask

                records = run_dask([Spec(k, args.seed) for k in keys], scheduler=args.scheduler, quick=args.quick,
                                   out=out, progress=progress)
                results = [result_of(r) for r in records]
            else:
                results = run_tasks([Task(k, out, args.seed) for k in keys], quick=args.quick, jobs=args.jobs,
                                    progress=progress)
    except RuntimeError as exc:
        print(f"urb sim sensitivity: {exc}", file=sys.stderr)
        return 2
    from .profiles import load

    path = write_report(out, results, seed=args.seed, quick=args.quick, overrides=load(profile).params,
                        wall_s=time.perf_counter() - t0, provenance=evidence.page_provenance(args.seed, keys))
    _, _, notes = sensitivity.summarize(results, out / "sensitivity", load(profile).title)
    for line in notes:
        print(f"  - {line}")
    bad = [r for r in results if not r.passed]
    for r in bad:
        print(f"{r.verdict} {r.key}: " + "; ".join(f"{c.name}: {c.measured}" for c in r.checks if not c.passed))
    print(f"{len(results)} points, {len(bad)} not measured; report: {path}")
    return 0 if not bad else 1


def _ready(cannot_write: str, out: Path) -> bool:
    """Check before a run of minutes that `out` can be written and the library builds; print why
    not (after `cannot_write`, for the folder) and return False when one cannot."""
    problem = _unwritable(out)
    if problem:
        print(f"{cannot_write} {out}: {problem}; choose another --out DIR", file=sys.stderr)
        return False
    try:
        check_loadable()
        ensure_library()
    except BuildError as exc:
        print(f"urb sim: {exc}", file=sys.stderr)
        return False
    return True


def _unwritable(out: Path) -> str | None:
    """Why the report folder cannot be written (None when it can): checked before a run of minutes."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.NamedTemporaryFile(dir=out):
            pass
    except OSError as exc:
        return exc.strerror or str(exc)
    return None


class _progress:
    """A rich progress bar (or nothing) as a Progress callable, used as a context manager."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._bar: Any = None
        self._task: Any = None

    def __enter__(self) -> Progress:
        if self.enabled:
            from rich.progress import BarColumn, Progress as Bar, TextColumn, TimeElapsedColumn

            self._bar = Bar(TextColumn("[bold]urb sim[/bold]"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                            TimeElapsedColumn(), TextColumn("{task.description}"), transient=True)
            self._bar.start()
            self._task = self._bar.add_task("starting", total=1.0)
        return self._update

    def _update(self, frac: float, msg: str) -> None:
        if self._bar is not None:
            self._bar.update(self._task, completed=min(frac, 1.0), description=msg)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.stop()
