# Frama-C proofs (proofs/framac/, tools/proofs_framac.py). Included by the top-level Makefile.
#   make proofs-framac          WP -wp-rte on the generated codecs, the node mailbox and the bridge FIFO,
#                               Eva over the node entry points, one seeded mutant per unit; WP replays the
#                               committed cache (proofs/framac/cache) and runs no prover: a goal that is
#                               not in it fails as CACHE MISS (in make check, so CI never waits on a prover)
#   make proofs-framac-update   the same, but proves the goals missing from the cache and adds their
#                               answers: run it after changing code or contracts under proof, then
#                               commit proofs/framac/cache with the change
#   make proofs-framac-record   re-record every unit's expected.json (goal counts, reviewed Eva alarms)
#                               after an intended change; review the diff before committing it
#   make proofs-framac-fresh    proofs-framac with every Frama-C run done now (FRAMAC_RESULT_CACHE=off:
#                               nothing replayed from proofs/framac/results, nothing recorded)
# Whole Frama-C runs (each Eva entry point, each offline WP unit, each mutant) whose inputs are
# byte-identical to a recorded run's are replayed from proofs/framac/results (tools/framac_cache.py;
# FRAMAC_RESULT_CACHE=off runs all, refresh re-records); a new run is recorded there: commit the new
# entries. Each run re-runs for real a sample of FRAMAC_RESULT_CACHE_VERIFY per mille of the replayed
# runs (those under 30 s of CPU), drawn from the commit, and fails a unit whose verdict differs.
# Results: build/proofs/framac/summary.json (rows: function, tool, properties, bound, result, expected,
# time_s, detail), junit.xml, logs/. Pulled into `make proofs` by mk/proofs.mk through PROOF_PARTS.
PYTHON ?= python3

FRAMAC_RESULT_CACHE_VERIFY ?= 40
FRAMAC_RESULT_CACHE_SEED ?= $(shell git rev-parse HEAD 2>/dev/null)

.PHONY: proofs-framac proofs-framac-fresh proofs-framac-update proofs-framac-record
proofs-framac:
	FRAMAC_RESULT_CACHE_VERIFY=$(FRAMAC_RESULT_CACHE_VERIFY) FRAMAC_RESULT_CACHE_SEED=$(FRAMAC_RESULT_CACHE_SEED) \
		$(PYTHON) tools/proofs_framac.py --cache offline

proofs-framac-fresh:
	FRAMAC_RESULT_CACHE=off $(PYTHON) tools/proofs_framac.py --cache offline

proofs-framac-update:
	$(PYTHON) tools/proofs_framac.py --cache update

proofs-framac-record:
	$(PYTHON) tools/proofs_framac.py --record --no-mutants

PROOF_PARTS += framac
