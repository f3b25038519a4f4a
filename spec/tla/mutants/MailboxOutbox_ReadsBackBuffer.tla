--------------------- MODULE MailboxOutbox_ReadsBackBuffer ---------------------
(* MUTANT of MailboxOutbox: the ISR latches isr_idx := 1 - front (confusing *)
(* which buffer front names) and sends the previous message.               *)
(* Expected: IsrReadFresh.                                                 *)
EXTENDS MailboxOutbox

MutReadBegin ==
    /\ isrPc = "idle"
    /\ isrIdx' = 1 - front
    /\ isrPc' = "copy" /\ isrGot' = <<>>
    /\ isrSnap' = released
    /\ UNCHANGED <<buf, front, appPc, w, appByte, writes, released>>

MutNext == AppNext \/ MutReadBegin \/ IsrReadByte \/ IsrReadEnd
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
