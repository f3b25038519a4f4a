---------------------- MODULE Rs485Poll_RetryUnknown ----------------------
(* MUTANT of Rs485Poll: the bridge sends a write again when its outcome is unknown (TIMEOUT), a retransmission URB does not have: the node stored the first (its answer was garbled) and stores the second. *)
(* Expected: StoredAtMostOnce *)
EXTENDS MCRs485Poll

RetryUnknown ==
    /\ phase = "done" /\ result = "TIMEOUT" /\ drivers = {}
    /\ phase' = "send" /\ drivers' = {BRIDGE}
    /\ cut' = FALSE /\ got' = "none" /\ stored' = "nothing" /\ garbled' = FALSE
    /\ from' = NOBODY /\ result' = "none" /\ due' = NOBODY
    /\ UNCHANGED <<k, storesOf, babbleLeft, babbledIdle, heard, reported>>
MutSpec == Init /\ [][Next \/ RetryUnknown]_vars
=============================================================================
