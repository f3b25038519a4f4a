-------------------------- MODULE Discovery_WaitForAck --------------------------
(* MUTANT of Discovery: the bridge re-polls an address until it            *)
(* acknowledges; an empty address blocks the scan for ever.                *)
(* Expected: DiscoveryCompletes (liveness).                                *)
EXTENDS MCDiscovery

MutScan(b) == cursor[b] <= NAddr /\ present[<<b, cursor[b]>>] /\ ScanAddress(b)
Poll(b) == cursor[b] <= NAddr /\ ~present[<<b, cursor[b]>>] /\ UNCHANGED vars

MutNext == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
           \/ \E b \in Bridges : MutScan(b) \/ Poll(b)
           \/ HostBuildTable \/ HostRequest \/ HostIdle
MutSpec == Init /\ [][MutNext]_vars
           /\ \A b \in Bridges : WF_vars(MutScan(b))
           /\ WF_vars(HostBuildTable)
=============================================================================
