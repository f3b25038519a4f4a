# Mutation score (tests/mutation/README.md). Included by the top-level Makefile; `make proofs` runs
# it as one of its parts (PROOF_PARTS), and its summary prints the mutation table of every tool.
#   make proofs-mutation    tools/c_mutate.py: the fixed sample of generated C mutants (3 per
#                           component and kind) against the components' cmocka tests (make check)
#   make mutation-c-full    every generated C mutant (opt-in; see the README for its size and time)
# Results: build/proofs/mutation/c.json, summary.json, junit.xml; the table in build/proofs/summary.md
# and build/evidence/mutation.json.
PYTHON ?= python3
MUTATION_JOBS ?= 2

.PHONY: proofs-mutation mutation-c-full
proofs-mutation: setup
	$(PYTHON) tools/c_mutate.py run --sample --jobs $(MUTATION_JOBS)

mutation-c-full: setup
	$(PYTHON) tools/c_mutate.py run --jobs $(MUTATION_JOBS)

PROOF_PARTS += mutation
