----------------------- MODULE MailboxInbox_SingleBuffer -----------------------
(* MUTANT of MailboxInbox: single-buffered inbox.  The ISR writes straight *)
(* into the published buffer, whatever the application holds.              *)
(* Expected: AppReadNotTorn.                                               *)
EXTENDS MailboxInbox

MutWriteBegin ==
    /\ isrPc = "idle" /\ txs < MaxWrites
    /\ txs' = txs + 1
    /\ isrIdx' = front /\ isrPc' = "fill" /\ isrByte' = 1
    /\ UNCHANGED <<buf, front, appIdx, appPc, a, tries, appGot, committed,
                   aborted, appSnap, callFails>>

MutNext == MutWriteBegin \/ IsrWriteByte \/ IsrWriteCommit \/ IsrWriteAbort
           \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
