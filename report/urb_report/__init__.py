"""URB's certification evidence: records that every verification activity writes (records.py),
and the report and gate that read them."""
