# libFuzzer on the C decoders, the bridge's uplink side and a node (tests/fuzz/README.md). Included by the
# top-level Makefile; `make proofs` runs it as one of its parts (PROOF_PARTS).
#   make fuzz              every target for FUZZ_SECONDS from the committed corpus, then each seeded
#                          mutant must be caught within FUZZ_MUTANT_SECONDS (results build/proofs/fuzz/)
#   make fuzz-long         a longer session (FUZZ_LONG_SECONDS per target), no mutants
#   make fuzz-merge        add the last run's new-coverage inputs to tests/fuzz/corpus/ (commit them)
FUZZ_SECONDS ?= 20
FUZZ_MUTANT_SECONDS ?= 60
FUZZ_LONG_SECONDS ?= 600

.PHONY: fuzz fuzz-long fuzz-merge
fuzz: setup
	$(PYTHON) tools/fuzz.py run --seconds $(FUZZ_SECONDS) --mutant-seconds $(FUZZ_MUTANT_SECONDS)

fuzz-long: setup
	$(PYTHON) tools/fuzz.py run --seconds $(FUZZ_LONG_SECONDS) --no-mutants

fuzz-merge:
	$(PYTHON) tools/fuzz.py merge

PROOF_PARTS += fuzz
