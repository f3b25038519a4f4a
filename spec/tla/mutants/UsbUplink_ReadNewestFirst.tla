----------------------- MODULE UsbUplink_ReadNewestFirst -----------------------
(* MUTANT of UsbUplink: the bridge answers the bulk-IN read with whichever *)
(* response buffer was filled last, so batch n can overtake batch n-1.     *)
(* Expected: ResponsesMatched.                                             *)
EXTENDS UsbUplink

MutRead ==
    /\ ~readDone
    /\ IF txCur # <<>>
         THEN hostRx' = hostRx \o txCur /\ txCur' = <<>> /\ UNCHANGED txPrev
         ELSE hostRx' = hostRx \o txPrev /\ txPrev' = <<>> /\ UNCHANGED txCur
    /\ readDone' = TRUE
    /\ UNCHANGED <<nextId, budget, hostQ, expect, rx, done, cbLog, age,
                   deferred, wrote>>

MutNext == Submit \/ UsbWrite \/ BridgeProcess \/ MutRead \/ Callback \/ Tick
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
