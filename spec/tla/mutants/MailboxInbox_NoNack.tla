-------------------------- MODULE MailboxInbox_NoNack --------------------------
(* MUTANT of MailboxInbox: the ISR does not look at app_idx and starts a   *)
(* write on the buffer the application holds.                              *)
(* Expected: AppLockExclusive.                                             *)
EXTENDS MailboxInbox

MutWriteBegin ==
    /\ isrPc = "idle" /\ txs < MaxWrites
    /\ txs' = txs + 1
    /\ isrIdx' = 1 - front /\ isrPc' = "fill" /\ isrByte' = 1
    /\ UNCHANGED <<buf, front, appIdx, appPc, a, tries, appGot, committed,
                   aborted, appSnap, callFails>>

MutNext == MutWriteBegin \/ IsrWriteByte \/ IsrWriteCommit \/ IsrWriteAbort
           \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
