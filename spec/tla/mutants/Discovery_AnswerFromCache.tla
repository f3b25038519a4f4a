----------------------- MODULE Discovery_AnswerFromCache -----------------------
(* MUTANT of Discovery: the bridge answers requests for a node it          *)
(* discovered from its cache, even after the node vanished.                *)
(* Expected: VanishedGetNoNode.                                            *)
EXTENDS MCDiscovery

MutRequest ==
    /\ built
    /\ \E r \in table :
         LET s == <<r.bridge, r.addr>> IN
         lastReq' = [slot |-> s, present |-> present[s], status |-> "OK"]
    /\ UNCHANGED <<pop, present, churn, cursor, found, table, built, stable>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : ScanAddress(b)
           \/ HostBuildTable \/ MutRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
