# Time-accurate SensoRHex simulation (sim/, firmware/hal/sim/). Included by the top-level Makefile.
#   make sim-lib      build build/sim/liburbsim.so (C core + firmware + simulation HALs), if stale
#   make test-sim     build the library and run the C unit tests of the core under ASan+UBSan, then
#                     check that they fail for each seeded kernel bug (SIM_MUTANTS)
#                     (the Python tests in tests/sim/ run in the main pytest run of `make check`)
#   make test-sim-san the experiments on an ASan+UBSan build of the whole simulation (firmware, HALs,
#                     world) and a leak check of its C API (tests/sim/world_leaks.c): no sanitizer
#                     report, and a seeded off-by-one (sim_log.h) and leak (world.c) are reported;
#                     its `urb sim sensorhex --quick` run is the one in make check that writes the
#                     evidence records build/evidence/sim-<experiment>.json (issue #36)
#   make sim-report   the full run: `urb sim sensorhex` (HTML summary in build/sim/report/, evidence
#                     records in build/evidence/)
#   make sim-bench    simulated seconds per wall-clock second, and scaling with the node count
#   make sim-bench-sensorhex  `urb sim sensorhex` end to end (issue #38): simulated seconds per wall and per
#                     CPU second of each experiment, TLC included, and of the whole command (opt-in, minutes;
#                     SIM_BENCH_HOST=c: the experiments' loops on the C host library, urb sim sensorhex --host c)
#   make sim-critical-check  the PRIMASK critical sections measured from the Cortex-M0+ images equal the
#                     committed sim/profiles/critical_sections.json that the hardware profiles use
#                     (python3 -m urb_sim.critical --write refreshes it; in make check)
#   make sim-sensitivity  the sensitivity study: Table I, latency and loop lag against interrupt jitter,
#                     timer resolution, crystal error, bus capacitance and heartbeat rate
#                     (build/sim/sensitivity/index.html; `make demo` runs it inside the full report)
#   make sim-sweep-dask   opt-in: a 200-seed sweep (SIM_DASK_SEEDS, SIM_DASK_ONLY) on a Dask cluster that
#                     it starts on loopback with SIM_DASK_WORKERS worker processes and stops after; prints
#                     the hash of all records (build/sim/sweep-dask/summary.json)
PYTHON ?= python3

SIM_BUILD := build/sim
SIM_CORE := sim/core
SIM_SAN_FLAGS := -std=c99 -g -O1 -Wall -Wextra -Werror -Wpedantic -Wconversion \
	-fsanitize=address,undefined -fno-sanitize-recover=all

.PHONY: sim-lib test-sim test-sim-san sim-report sim-bench sim-bench-sensorhex sim-critical-check sim-sensitivity sim-sweep-dask
sim-lib:
	$(PYTHON) -m urb_sim.build

$(SIM_BUILD)/test_core: tests/sim/test_core.c $(wildcard $(SIM_CORE)/*.c $(SIM_CORE)/*.h)
	@mkdir -p $(@D)
	$(CC) $(SIM_SAN_FLAGS) -I$(SIM_CORE) tests/sim/test_core.c $(wildcard $(SIM_CORE)/*.c) -lm -o $@

# Seeded bugs (#ifdef URBSIM_MUTANT_* in sim/core): the event order of the two-queue kernel on ties
# (kernel.c), the cached span of a clock's newest segment (clock.c), a handle that loses track of its
# event in the far queue (kernel.c), a NAKed USB transaction retried behind URBs submitted after its
# frame began (usb.c), a main loop that runs over a handler already running or reserved (mcu.c), an
# interrupt raised in the idle path's PRIMASK section that is not held back (mcu.c, hardware profiles).
# The unit tests must fail for each.
SIM_MUTANTS := RING_TIES QUEUE_TIES CLOCK_SPAN CANCEL_SLOT NAK_TAIL THREAD_OVER_ISR MASK_IGNORED

$(SIM_BUILD)/mutants/%/test_core: tests/sim/test_core.c $(wildcard $(SIM_CORE)/*.c $(SIM_CORE)/*.h)
	@mkdir -p $(@D)
	$(CC) $(SIM_SAN_FLAGS) -DURBSIM_MUTANT_$* -I$(SIM_CORE) tests/sim/test_core.c $(wildcard $(SIM_CORE)/*.c) -lm -o $@

test-sim: sim-lib $(SIM_BUILD)/test_core $(foreach m,$(SIM_MUTANTS),$(SIM_BUILD)/mutants/$(m)/test_core)
	$(SIM_BUILD)/test_core
	@for m in $(SIM_MUTANTS); do \
	  if $(SIM_BUILD)/mutants/$$m/test_core >/dev/null 2>&1; then \
	    echo "test-sim: mutant $$m survived: tests/sim/test_core.c no longer catches the bug seeded under URBSIM_MUTANT_$$m in sim/core" >&2; exit 1; \
	  fi; echo "test-sim: mutant $$m caught"; done

test-sim-san: setup
	$(PYTHON) tools/sim_sanitized.py

sim-report: setup accel host-c-py
	urb sim sensorhex

sim-bench: setup
	$(PYTHON) bench/sim_speed.py

SIM_BENCH_HOST ?= python
sim-bench-sensorhex: setup sim-lib host-c-py accel
	$(PYTHON) bench/sim_speed.py --sensorhex --host $(SIM_BENCH_HOST)

sim-critical-check: setup cross-firmware-node build/firmware/urb-bridge-cm0plus.elf
	$(PYTHON) -m urb_sim.critical --check

sim-sensitivity: setup
	urb sim sensitivity

SIM_DASK_SEEDS ?= 0-4179/21
SIM_DASK_ONLY ?= fig15,fig16
SIM_DASK_WORKERS ?= 2
sim-sweep-dask: setup sim-lib
	$(PYTHON) -m urb_sim.loopback --workers $(SIM_DASK_WORKERS) -- --seeds $(SIM_DASK_SEEDS) --only $(SIM_DASK_ONLY) \
	    --quick --no-progress --out build/sim/sweep-dask

CHECK_TARGETS += test-sim test-sim-san sim-critical-check
