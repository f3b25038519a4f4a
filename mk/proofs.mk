# Proofs (proofs/README.md). Included by the top-level Makefile.
#   make proofs          every proof part, fast tier, then the merged summary (in make check):
#                        build/proofs/summary.md (table, worst-case cycles vs budgets), build/proofs/junit.xml
#   make proofs-bmc      ESBMC: every proofs/bmc/*/ folder (codecs urb_*, firmware fw_*), its mutants and
#                        its cover points (replayed from proofs/bmc/cache; deferred folders: covers_deferred.json)
#   make proofs-full     ESBMC complete tier: every sweep item, each COST's worst-case witness and the
#                        cover points (on demand)
#   make proofs-cover    ESBMC fast tier with every folder's cover points (URB_COVER) checked, the deferred
#                        ones too, no mutants (records the cover runs; see proofs/README.md, Cover points)
#   make proofs-fresh    proofs-bmc with every ESBMC run done now (BMC_CACHE=off: no replay, nothing recorded)
#   make proofs-costs    re-record each BMC proof's worst-case cycles (proofs/bmc/*/COST)
#   make proofs-summary  merge the parts' results again (fails when a part is missing or unexpected)
# Each proof part's fragment appends its name to PROOF_PARTS and defines its target (bmc: proofs-bmc,
# framac: proofs-framac, fuzz: fuzz); each writes build/proofs/<part>/summary.json and junit.xml.
PYTHON ?= python3

PROOF_PARTS += bmc
# The parts `make proofs` must find results of; a part whose fragment is missing fails the summary.
PROOF_PARTS_REQUIRED ?= bmc framac fuzz

.PHONY: proofs proofs-bmc proofs-fresh proofs-full proofs-cover proofs-costs proofs-summary
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

# ESBMC runs whose inputs are byte-identical to a recorded run's are replayed from proofs/bmc/cache
# (proofs/bmc/bmc_cache.py; BMC_CACHE=off runs all, refresh re-records). Each run re-runs for real a
# sample of BMC_CACHE_VERIFY per mille of the replayed runs (those under 30 s of CPU), drawn from the
# commit, and fails on any verdict that differs from the recorded one.
BMC_CACHE_VERIFY ?= 25
BMC_CACHE_SEED ?= $(shell git rev-parse HEAD 2>/dev/null)
# make check judges every folder's cover points (--covers): their reach runs are recorded in the cache
# like the proofs', so they replay; a folder whose cover runs are not recorded is listed with its reason
# in proofs/bmc/covers_deferred.json (plain vacuity check, a [cover] row "deferred"), and
# tests/proofs/test_bmc_covers_in_check.py fails on a folder that is neither.
proofs-bmc:
	BMC_CACHE_VERIFY=$(BMC_CACHE_VERIFY) BMC_CACHE_SEED=$(BMC_CACHE_SEED) $(PYTHON) tools/proofs.py --tier fast --covers --covers-deferred proofs/bmc/covers_deferred.json

proofs-fresh:
	BMC_CACHE=off $(PYTHON) tools/proofs.py --tier fast

proofs-full:
	$(PYTHON) tools/proofs.py --tier full --covers

proofs-cover:
	$(PYTHON) tools/proofs.py --tier fast --covers --no-mutants

proofs-costs:
	$(PYTHON) tools/proofs.py --update-costs --tier fast

proofs-summary:
	$(PYTHON) tools/proofs.py summary --parts "$(sort $(PROOF_PARTS_REQUIRED) $(PROOF_PARTS))"

CHECK_TARGETS += proofs
