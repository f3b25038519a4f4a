------------------------ MODULE Discovery_IdleBusAsNode ------------------------
(* MUTANT of Discovery: the bridge reads outbox 0 without checking the     *)
(* address acknowledge; the idle bus (all ones) is decoded as a node.      *)
(* Expected: NoPhantoms.                                                   *)
EXTENDS MCDiscovery

Garbage == CHOOSE i \in Idents : TRUE
MutScan(b) ==
    /\ cursor[b] <= NAddr
    /\ LET s == <<b, cursor[b]>> IN
         found' = [found EXCEPT ![b] = @ \cup
                     {[addr |-> cursor[b], id |-> IF present[s] THEN pop[s] ELSE Garbage]}]
    /\ cursor' = [cursor EXCEPT ![b] = @ + 1]
    /\ UNCHANGED <<pop, present, churn, table, built, stable, lastReq>>

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : MutScan(b)
           \/ HostBuildTable \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
