------------------------ MODULE UsbUplink_BatchOffByOne ------------------------
(* MUTANT of UsbUplink: the write thread packs one request fewer than the  *)
(* batch capacity, so even within the submission budget a request waits a *)
(* frame.  (Deferrals are counted, so LatencyBound still holds.)           *)
(* Expected: StrictLatency.                                                *)
EXTENDS UsbUplink

MutWrite ==
    /\ ~wrote
    /\ LET batch == Take(hostQ, Min(MaxBatch - 1, Window - Len(expect)))
           rest == Drop(hostQ, Min(MaxBatch - 1, Window - Len(expect)))
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
