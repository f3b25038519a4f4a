------------------- MODULE Discovery_FingerprintOfWrongClass -------------------
(* MUTANT of Discovery: the fingerprint is compared with the layout        *)
(* expected for the class of the first node of the system (ClassA), not    *)
(* the node's own class: a ClassA node with ClassB's layout passes, a      *)
(* correct ClassB node is flagged MISMATCH.  Passed when every class       *)
(* expected the same fingerprint.                                          *)
(* Expected: MismatchReported.                                             *)
EXTENDS MCDiscovery

MutFlags(f) ==
    (IF \E g \in AllFound : g # f /\ g.id.class = f.id.class /\ g.id.index = f.id.index
       THEN {"DUPLICATE"} ELSE {})
    \cup (IF f.id.fp # Expected[ClassA] THEN {"MISMATCH"} ELSE {})

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
