------------------------ MODULE UsbUplink_WaitFullBatch ------------------------
(* MUTANT of UsbUplink: to "save bandwidth" the write thread only sends    *)
(* full batches; a lone request waits forever if the application stops     *)
(* submitting.  Expected: EveryCallbackRuns (liveness).                    *)
EXTENDS UsbUplink

MutWrite ==
    \/ Len(hostQ) >= MaxBatch /\ UsbWrite
    \/ /\ Len(hostQ) < MaxBatch /\ ~wrote
       /\ wrote' = TRUE /\ budget' = 0
       /\ UNCHANGED <<nextId, hostQ, expect, rx, txPrev, txCur, hostRx, done,
                      cbLog, age, deferred, readDone>>

MutNext == Submit \/ MutWrite \/ BridgeProcess \/ UsbRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars /\ WF_vars(Tick) /\ WF_vars(MutWrite)
           /\ WF_vars(UsbRead) /\ WF_vars(BridgeProcess) /\ WF_vars(Callback)
=============================================================================
