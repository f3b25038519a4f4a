--------------------- MODULE UsbUplink_SingleResponseBuffer ---------------------
(* MUTANT of UsbUplink: the bridge has ONE response buffer; processing     *)
(* batch n overwrites the responses of batch n-1 before the host's read    *)
(* of this frame fetched them (the pipeline drops the second transaction). *)
(* Expected: NothingLost.                                                  *)
EXTENDS UsbUplink

MutProcess ==
    /\ rx # <<>>
    /\ txPrev' = [k \in DOMAIN rx |-> [id |-> rx[k], seq |-> rx[k] % SeqMod]]
    /\ rx' = <<>>
    /\ UNCHANGED <<nextId, budget, hostQ, expect, txCur, hostRx, done, cbLog,
                   age, deferred, wrote, readDone>>

MutNext == Submit \/ UsbWrite \/ MutProcess \/ UsbRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
