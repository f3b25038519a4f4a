--------------------- MODULE MailboxInbox_NackOnAnyClaim ---------------------
(* MUTANT of MailboxInbox: the ISR NACKs a write whenever the application *)
(* has claimed any buffer (app_idx # NONE instead of app_idx = 1 - front): *)
(* safe, but it refuses writes it could take into the free buffer.         *)
(* Expected: NackOnlyWhenClaimed.                                          *)
EXTENDS MailboxInbox

MutWriteBegin ==
    /\ isrPc = "idle" /\ txs < MaxWrites
    /\ txs' = txs + 1
    /\ IF appIdx # NONE
         THEN UNCHANGED <<isrIdx, isrPc, isrByte>>
         ELSE /\ isrIdx' = 1 - front
              /\ isrPc' = "fill" /\ isrByte' = 1
    /\ UNCHANGED <<buf, front, appIdx, appPc, a, tries, appGot, committed,
                   aborted, appSnap, callFails>>

MutNext == MutWriteBegin \/ IsrWriteByte \/ IsrWriteCommit \/ IsrWriteAbort \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
