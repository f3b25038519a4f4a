------------------------ MODULE UsbUplink_NoPipelining ------------------------
(* MUTANT of UsbUplink: the write thread waits until the previous batch's  *)
(* responses are back before sending the next batch (write/read strictly   *)
(* alternate, half the bandwidth).  Expected: LatencyBound.                *)
EXTENDS UsbUplink

MutWrite ==
    \/ expect = <<>> /\ UsbWrite
    \/ /\ expect # <<>> /\ ~wrote
       /\ wrote' = TRUE
       /\ UNCHANGED <<nextId, budget, hostQ, expect, rx, txPrev, txCur, hostRx,
                      done, cbLog, age, deferred, readDone>>

MutNext == Submit \/ MutWrite \/ BridgeProcess \/ UsbRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
