---------------------- MODULE MailboxOutbox_NoBusyCheck ----------------------
(* MUTANT of MailboxOutbox: URB_LockOutbox skips step 2 (the load of       *)
(* isr_idx) and always succeeds.  After two quick releases the application *)
(* locks the buffer the ISR is still sending.                              *)
(* Expected: AppLockExclusive.                                             *)
EXTENDS MailboxOutbox

MutLockCheck ==
    /\ appPc = "check"
    /\ appPc' = "write" /\ appByte' = 1
    /\ UNCHANGED <<buf, front, isrIdx, w, writes, isrPc, isrGot, released, isrSnap>>

MutNext == AppLockPick \/ MutLockCheck \/ AppWriteByte \/ AppRelease \/ IsrNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
