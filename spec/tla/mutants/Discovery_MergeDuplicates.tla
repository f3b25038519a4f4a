----------------------- MODULE Discovery_MergeDuplicates -----------------------
(* MUTANT of Discovery: the host keys its table by (class, index), so two  *)
(* nodes with the same identity collapse into one row.                     *)
(* Expected: NeverMerged.                                                  *)
EXTENDS MCDiscovery

Key(f) == <<f.id.class, f.id.index>>
MutBuild ==
    /\ ScanDone /\ ~built
    /\ table' = { ToRow(CHOOSE f \in AllFound : Key(f) = k) : k \in { Key(g) : g \in AllFound } }
    /\ built' = TRUE
    /\ UNCHANGED <<pop, present, churn, cursor, found, stable, lastReq>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : ScanAddress(b)
           \/ MutBuild \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
