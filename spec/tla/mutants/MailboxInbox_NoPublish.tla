------------------------ MODULE MailboxInbox_NoPublish ------------------------
(* MUTANT of MailboxInbox: the commit forgets front := isr_idx; the        *)
(* application keeps reading the old message.  Expected: AppReadFresh.     *)
EXTENDS MailboxInbox

MutWriteCommit ==
    /\ isrPc = "fill" /\ isrByte = MsgLen + 1
    /\ isrIdx' = NONE /\ isrPc' = "idle"
    /\ committed' = txs
    /\ UNCHANGED <<buf, front, appIdx, isrByte, txs, appPc, a, tries, appGot,
                   aborted, appSnap, callFails>>

MutNext == IsrWriteBegin \/ IsrWriteByte \/ MutWriteCommit \/ IsrWriteAbort
           \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
