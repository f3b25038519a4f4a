# TLA+ model checking (spec/tla). Included by the top-level Makefile (`include mk/*.mk`).
# `make modelcheck` runs TLC on every model and must-fail mutant in spec/tla/manifest.json,
# compares results with the manifest and writes build/tla/junit.xml.
# Standalone: make -f mk/tla.mk modelcheck
PYTHON ?= python3

.PHONY: modelcheck modelcheck-update modelcheck-large
modelcheck:
	$(PYTHON) tools/modelcheck.py

# Re-record state counts after an intended spec change (review the diff of the manifest).
modelcheck-update:
	$(PYTHON) tools/modelcheck.py --update

# Opt-in larger configurations (more nodes, deeper FIFOs); needs more cores and time.
modelcheck-large:
	$(PYTHON) tools/modelcheck.py --optional --only Large

CHECK_TARGETS += modelcheck
