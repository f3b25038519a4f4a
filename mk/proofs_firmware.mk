# Firmware proofs (proofs/bmc/fw_*/, proofs/FIRMWARE.md). Included by the top-level Makefile.
#   make proofs-firmware        fast tier: every firmware proof and every seeded mutant (in make check)
#   make proofs-firmware-full   the larger bounds, plus the worst-case witness of each COST
#   make proofs-firmware-costs  search each proof's worst-case cycle count and rewrite its COST file
# Table of functions, bounds, results, times and worst-case cycles at 48 MHz against the budgets:
# build/proofs/firmware/<tier>/summary.md (also summary.json, junit.xml; ESBMC logs in logs/).
PYTHON ?= python3

.PHONY: proofs-firmware proofs-firmware-full proofs-firmware-costs
proofs-firmware:
	$(PYTHON) tools/proofs_firmware.py --tier fast

proofs-firmware-full:
	$(PYTHON) tools/proofs_firmware.py --tier full --tight

proofs-firmware-costs:
	$(PYTHON) tools/proofs_firmware.py --tier fast --update-costs --no-mutants

CHECK_TARGETS += proofs-firmware
