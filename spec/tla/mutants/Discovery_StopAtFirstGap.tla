------------------------ MODULE Discovery_StopAtFirstGap ------------------------
(* MUTANT of Discovery: the bridge ends its scan at the first address that *)
(* does not acknowledge, missing the nodes behind the gap.                 *)
(* Expected: StableNodesFound.                                             *)
EXTENDS MCDiscovery

MutScan(b) ==
    /\ cursor[b] <= NAddr
    /\ LET s == <<b, cursor[b]>> IN
         IF present[s]
           THEN /\ found' = [found EXCEPT ![b] = @ \cup {[addr |-> cursor[b], id |-> pop[s]]}]
                /\ cursor' = [cursor EXCEPT ![b] = @ + 1]
           ELSE /\ cursor' = [cursor EXCEPT ![b] = NAddr + 1]
                /\ UNCHANGED found
    /\ UNCHANGED <<pop, present, churn, table, built, stable, lastReq>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : MutScan(b)
           \/ HostBuildTable \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
