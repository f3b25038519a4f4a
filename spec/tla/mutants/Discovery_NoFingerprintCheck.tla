---------------------- MODULE Discovery_NoFingerprintCheck ----------------------
(* MUTANT of Discovery: the host trusts class and index and never compares *)
(* the layout fingerprint.  Expected: MismatchReported.                    *)
EXTENDS MCDiscovery

MutFlags(f) ==
    IF \E g \in AllFound : g # f /\ g.id.class = f.id.class /\ g.id.index = f.id.index
      THEN {"DUPLICATE"} ELSE {}

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
