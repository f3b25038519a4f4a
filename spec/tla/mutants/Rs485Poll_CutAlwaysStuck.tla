---------------------- MODULE Rs485Poll_CutAlwaysStuck ----------------------
(* MUTANT of Rs485Poll: the master before 2026-11-29: every collision before the request's last byte is reported BUS_STUCK (not executed), though the bytes the line carried may form a shorter frame whose check passes and the node stores it (fuzz_rs485's regress-rs485-cut-frame-passes-check). *)
(* Expected: StatusTruthful *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMidWith(FALSE), SendEnd, Silence, BabbleStart)]_vars
=============================================================================
