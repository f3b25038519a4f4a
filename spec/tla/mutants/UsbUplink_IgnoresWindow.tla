------------------------ MODULE UsbUplink_IgnoresWindow ------------------------
(* MUTANT of UsbUplink: the write thread fills every batch to MaxBatch     *)
(* whatever is still in flight (UsbCore.frame_out without its window       *)
(* test), so more requests are outstanding than the bridge has room for.   *)
(* Expected: WindowRespected.                                              *)
EXTENDS UsbUplink

MutWrite ==
    /\ ~wrote
    /\ LET batch == Take(hostQ, MaxBatch)
           rest == Drop(hostQ, MaxBatch)
       IN /\ rx' = batch
          /\ hostQ' = rest
          /\ expect' = expect \o batch
          /\ deferred' = [i \in Ids |-> IF i \in Range(rest)
                                          THEN deferred[i] + 1 ELSE deferred[i]]
    /\ wrote' = TRUE /\ budget' = 0
    /\ UNCHANGED <<nextId, txPrev, txCur, hostRx, done, cbLog, age, readDone>>

MutNext == Submit \/ MutWrite \/ BridgeProcess \/ UsbRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
