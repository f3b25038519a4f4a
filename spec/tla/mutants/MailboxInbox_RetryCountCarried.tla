------------------- MODULE MailboxInbox_RetryCountCarried -------------------
(* MUTANT of MailboxInbox: a lock that succeeds keeps its retry count      *)
(* (AppLockCheckFront does not reset tries), so the next lock call starts  *)
(* with it and gives up (URB_BUSY) before it has made MaxRetry retries.    *)
(* Expected: LockFailsOnlyOnConflict (its count per lock call, callFails). *)
EXTENDS MailboxInbox

MutCheckFront ==
    /\ appPc = "checkFront"
    /\ IF front # a
         THEN LockFail /\ UNCHANGED <<appGot, appSnap, callFails>>
         ELSE /\ appPc' = "read" /\ appGot' = <<>>
              /\ appSnap' = committed /\ callFails' = 0
              /\ UNCHANGED <<appIdx, tries>>
    /\ UNCHANGED <<buf, front, isrIdx, a, isrPc, isrByte, txs, committed,
                   aborted>>

MutNext == IsrNext \/ AppLockLoadFront \/ AppLockClaim \/ AppLockCheckIsr
           \/ MutCheckFront \/ AppLockUnclaim \/ AppReadByte \/ AppRelease
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
