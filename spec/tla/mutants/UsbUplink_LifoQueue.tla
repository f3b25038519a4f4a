------------------------- MODULE UsbUplink_LifoQueue -------------------------
(* MUTANT of UsbUplink: the write thread's buffer is a stack: a request    *)
(* submitted later is sent before one submitted earlier.  Responses are    *)
(* matched by sequence number and the latency bounds still hold (the       *)
(* mutation run found it survived before SubmissionOrderKept).             *)
(* Expected: SubmissionOrderKept.                                          *)
EXTENDS UsbUplink

MutSubmit ==
    /\ nextId < MaxReq /\ budget < MaxSubmit
    /\ nextId' = nextId + 1 /\ budget' = budget + 1
    /\ hostQ' = <<nextId + 1>> \o hostQ
    /\ UNCHANGED <<expect, rx, txPrev, txCur, hostRx, done, cbLog, age,
                   deferred, wrote, readDone>>

MutNext == MutSubmit \/ UsbWrite \/ BridgeProcess \/ UsbRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
