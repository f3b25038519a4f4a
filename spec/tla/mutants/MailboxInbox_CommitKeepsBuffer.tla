-------------------- MODULE MailboxInbox_CommitKeepsBuffer --------------------
(* MUTANT of MailboxInbox: the ISR publishes a committed write but never  *)
(* frees its buffer (IsrWriteCommit leaves isr_idx set).  The application *)
(* then fails every lock of the newest message on step 3 although no     *)
(* write is in progress.                                                   *)
(* Expected: LockFailsOnlyOnConflict.                                      *)
EXTENDS MailboxInbox

MutCommit ==
    /\ isrPc = "fill" /\ isrByte = MsgLen + 1
    /\ front' = isrIdx
    /\ isrPc' = "idle"
    /\ committed' = txs
    /\ UNCHANGED <<buf, isrIdx, appIdx, isrByte, txs, appPc, a, tries, appGot,
                   aborted, appSnap, callFails>>

MutNext == IsrWriteBegin \/ IsrWriteByte \/ MutCommit \/ IsrWriteAbort \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
