-------------------- MODULE Discovery_DuplicateIgnoresIndex --------------------
(* MUTANT of Discovery: the duplicate test compares the class only, so two *)
(* nodes of one class with different indices are flagged DUPLICATE (and    *)
(* findNode refuses both).  Passed when every node had index 0.            *)
(* Expected: DuplicatesReported.                                           *)
EXTENDS MCDiscovery

MutFlags(f) ==
    (IF \E g \in AllFound : g # f /\ g.id.class = f.id.class
       THEN {"DUPLICATE"} ELSE {})
    \cup (IF f.id.fp # Expected[f.id.class] THEN {"MISMATCH"} ELSE {})

MutBuild ==
    /\ ScanDone /\ ~built
    /\ table' = { [bridge |-> f.bridge, addr |-> f.addr, class |-> f.id.class,
                   index |-> f.id.index, fp |-> f.id.fp, flags |-> MutFlags(f)]
                  : f \in AllFound }
    /\ built' = TRUE
    /\ UNCHANGED <<pop, present, churn, cursor, found, stable, lastReq>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : ScanAddress(b)
           \/ MutBuild \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
