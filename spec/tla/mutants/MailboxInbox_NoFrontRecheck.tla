--------------------- MODULE MailboxInbox_NoFrontRecheck ---------------------
(* MUTANT of MailboxInbox: the inbox lock as first designed, without the   *)
(* re-check of front (step 4).  The read linearizes at its only load of     *)
(* front (step 1).  TLC finds an aborted ISR write on the claimed buffer:  *)
(* the application reads a half-written, never-committed message.          *)
(* Expected: NoAbortedDelivered.                                           *)
EXTENDS MailboxInbox

MutLoadFront ==
    /\ appPc = "idle"
    /\ a' = front /\ appSnap' = committed
    /\ appPc' = "claim"
    /\ UNCHANGED <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, tries,
                   appGot, committed, aborted, callFails>>

MutCheckIsr ==
    /\ appPc = "checkIsr"
    /\ IF isrIdx = a
         THEN LockFail /\ UNCHANGED <<appGot, callFails>>
         ELSE /\ appPc' = "read" /\ appGot' = <<>> /\ tries' = 0 /\ callFails' = 0
              /\ UNCHANGED appIdx
    /\ UNCHANGED <<buf, front, isrIdx, a, isrPc, isrByte, txs, committed,
                   aborted, appSnap>>

MutNext == IsrNext \/ MutLoadFront \/ AppLockClaim \/ MutCheckIsr \/ AppLockUnclaim
           \/ AppReadByte \/ AppRelease
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
