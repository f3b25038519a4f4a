# Proofs (proofs/README.md). Included by the top-level Makefile.
#   make proofs          every proof part, fast tier, then the merged summary (in make check):
#                        build/proofs/summary.md (table, worst-case cycles vs budgets), build/proofs/junit.xml
#   make proofs-bmc      ESBMC: every proofs/bmc/*/ folder (codecs urb_*, firmware fw_*) and its mutants
#   make proofs-full     ESBMC complete tier: every sweep item, each COST's worst-case witness and the
#                        cover points (on demand)
#   make proofs-cover    ESBMC fast tier with the cover points (URB_COVER) checked, no mutants (on demand:
#                        costly, see proofs/README.md, Cover points)
#   make proofs-costs    re-record each BMC proof's worst-case cycles (proofs/bmc/*/COST)
#   make proofs-summary  merge the parts' results again (fails when a part is missing or unexpected)
# Each proof part's fragment appends its name to PROOF_PARTS and defines its target (bmc: proofs-bmc,
# framac: proofs-framac, fuzz: fuzz); each writes build/proofs/<part>/summary.json and junit.xml.
PYTHON ?= python3

PROOF_PARTS += bmc
# The parts `make proofs` must find results of; a part whose fragment is missing fails the summary.
PROOF_PARTS_REQUIRED ?= bmc framac fuzz

.PHONY: proofs proofs-bmc proofs-full proofs-cover proofs-costs proofs-summary
# Every part runs even when an earlier one fails, so the summary shows all of them; the recipe is
# expanded after every fragment is read, so parts defined in later fragments are included.
proofs:
	@status=0; \
	for part in $(sort $(PROOF_PARTS)); do \
	  case $$part in fuzz) target=fuzz;; *) target=proofs-$$part;; esac; \
	  rm -f build/proofs/$$part/summary.json; \
	  $(MAKE) --no-print-directory $$target || status=1; \
	done; \
	$(PYTHON) tools/proofs.py summary --parts "$(sort $(PROOF_PARTS_REQUIRED) $(PROOF_PARTS))" || status=1; \
	exit $$status

proofs-bmc:
	$(PYTHON) tools/proofs.py --tier fast

proofs-full:
	$(PYTHON) tools/proofs.py --tier full --covers

proofs-cover:
	$(PYTHON) tools/proofs.py --tier fast --covers --no-mutants

proofs-costs:
	$(PYTHON) tools/proofs.py --update-costs --tier fast

proofs-summary:
	$(PYTHON) tools/proofs.py summary --parts "$(sort $(PROOF_PARTS_REQUIRED) $(PROOF_PARTS))"

CHECK_TARGETS += proofs
