--------------------- MODULE MailboxOutbox_IsrKeepsBuffer ---------------------
(* MUTANT of MailboxOutbox: the ISR never frees its buffer after a read    *)
(* (IsrReadEnd leaves isr_idx set).  Every safety invariant still holds,   *)
(* but once the application has released into the other buffer, its next *)
(* lock wants the one the idle ISR still names and is refused for ever,   *)
(* unless the bridge happens to read again.                                *)
(* Expected: WritesPublished.                                              *)
EXTENDS MailboxOutbox

MutReadEnd ==
    /\ isrPc = "copy"
    /\ isrPc' = "idle" /\ isrGot' = <<>>
    /\ UNCHANGED <<buf, front, isrIdx, appPc, w, appByte, writes, released, isrSnap>>

MutNext == AppNext \/ IsrReadBegin \/ IsrReadByte \/ MutReadEnd
MutSpec == Init /\ [][MutNext]_vars /\ WF_vars(AppNext) /\ WF_vars(MutReadEnd)
=============================================================================
