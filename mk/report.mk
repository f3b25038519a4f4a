# The certification evidence report (spec/requirements/, report/urb_report/). Included by the
# top-level Makefile. Both targets only read: the requirements, the evidence records every
# activity wrote under build/evidence/, the source markers and build/sim/report/'s figures.
#   make report        build/report/index.html and build/report/report.pdf; prints the gate's verdict
#   make report-gate   the gate alone (HTML, no PDF): fails when a requirement is not fully verified on
#                      this tree. `make check` runs it last, after every activity wrote its record.
.PHONY: report report-gate
report: setup
	urb report

report-gate: setup
	urb report --gate --no-pdf
