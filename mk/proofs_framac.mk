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
# Results: build/proofs/framac/summary.json (rows: function, tool, properties, bound, result, expected,
# time_s, detail), junit.xml, logs/. Pulled into `make proofs` by mk/proofs.mk through PROOF_PARTS.
PYTHON ?= python3

.PHONY: proofs-framac proofs-framac-update proofs-framac-record
proofs-framac:
	$(PYTHON) tools/proofs_framac.py --cache offline

proofs-framac-update:
	$(PYTHON) tools/proofs_framac.py --cache update

proofs-framac-record:
	$(PYTHON) tools/proofs_framac.py --record --no-mutants

PROOF_PARTS += framac
