------------------------- MODULE Discovery_DropVanished -------------------------
(* MUTANT of Discovery: when building its table the host drops the nodes   *)
(* that no longer answer, so a node read during the scan silently          *)
(* disappears instead of being reported and answered NO_NODE.              *)
(* Expected: VanishedNodesKept.                                            *)
EXTENDS MCDiscovery

MutBuild ==
    /\ ScanDone /\ ~built
    /\ table' = { ToRow(f) : f \in { g \in AllFound : present[<<g.bridge, g.addr>>] } }
    /\ built' = TRUE
    /\ UNCHANGED <<pop, present, churn, cursor, found, stable, lastReq>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : ScanAddress(b)
           \/ MutBuild \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
