# TLA+ model checking (spec/tla). Included by the top-level Makefile (`include mk/*.mk`).
# `make modelcheck` runs TLC on every model (with its reachability witnesses) and must-fail
# mutant in spec/tla/manifest.json, the distributed loopback check, and a fixed sample of the
# generated mutants (tools/tla_mutate.py --sample); it writes build/tla/junit.xml,
# build/evidence/tlc.json, build/evidence/tlc-mutation.json and build/proofs/mutation/tlc.json.
# Standalone: make -f mk/tla.mk modelcheck
PYTHON ?= python3
# TLCWorkers started on this machine by modelcheck-large-distributed
TLC_LOCAL_WORKERS ?= 1

.PHONY: modelcheck modelcheck-update modelcheck-large modelcheck-large-distributed modelcheck-mutate
modelcheck:
	$(PYTHON) tools/modelcheck.py
	$(PYTHON) tools/tla_mutate.py --sample

# Re-record state counts after an intended spec change (review the diff of the manifest).
modelcheck-update:
	$(PYTHON) tools/modelcheck.py --update

# Opt-in larger configurations (more nodes, deeper FIFOs); needs more cores and time.
modelcheck-large:
	$(PYTHON) tools/modelcheck.py --optional --only Large

# The same with TLC's distributed mode (TLCServer + TLCWorkers over RMI, on loopback here; see
# tools/tla_distributed.py for workers on other machines). Safety only: no liveness, no witnesses.
modelcheck-large-distributed:
	$(PYTHON) tools/modelcheck.py --optional --only Large --distributed --local-workers $(TLC_LOCAL_WORKERS)

# Every generated mutant of the specifications (long: see spec/tla/README.md, "Mutation score");
# records the results in spec/tla/mutation/results.json (commit it after a spec change). One module:
#   make modelcheck-mutate TLA_MUTATE_MODULE=MailboxInbox
TLA_MUTATE_JOBS ?= 1
TLA_MUTATE_MODULE ?=
modelcheck-mutate:
	$(PYTHON) tools/tla_mutate.py --record --jobs $(TLA_MUTATE_JOBS) $(if $(TLA_MUTATE_MODULE),--only $(TLA_MUTATE_MODULE)/)

CHECK_TARGETS += modelcheck
