# Frama-C proofs (proofs/framac/, tools/proofs_framac.py). Included by the top-level Makefile.
#   make proofs-framac          WP -wp-rte on the generated codecs, the node mailbox and the bridge FIFO,
#                               Eva over the node entry points, one seeded mutant per unit; replays the
#                               committed WP cache (proofs/framac/cache), so only changed goals run provers
#   make proofs-framac-record   re-record every unit's expected.json (goal counts, reviewed Eva alarms)
#                               after an intended change; review the diff before committing it
# Results: build/proofs/framac/summary.json (rows: function, tool, properties, bound, result, expected,
# time_s, detail), junit.xml, logs/. Pulled into `make proofs` by mk/proofs.mk through PROOF_PARTS.
PYTHON ?= python3

.PHONY: proofs-framac proofs-framac-record
proofs-framac:
	$(PYTHON) tools/proofs_framac.py

proofs-framac-record:
	$(PYTHON) tools/proofs_framac.py --record --no-mutants

PROOF_PARTS += framac
