---------------------- MODULE MailboxOutbox_SingleBuffer ----------------------
(* MUTANT of MailboxOutbox: single-buffered outbox.  The application writes *)
(* straight into the published buffer, with no check of isr_idx.           *)
(* Expected: IsrReadNotTorn (the ISR sends bytes of two different writes). *)
EXTENDS MailboxOutbox

MutLockPick ==
    /\ appPc = "idle" /\ writes < MaxWrites
    /\ w' = front /\ appPc' = "write" /\ appByte' = 1
    /\ UNCHANGED <<buf, front, isrIdx, writes, isrPc, isrGot, released, isrSnap>>

MutNext == MutLockPick \/ AppWriteByte \/ AppRelease \/ IsrNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
