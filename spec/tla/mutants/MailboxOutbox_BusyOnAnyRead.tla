--------------------- MODULE MailboxOutbox_BusyOnAnyRead ---------------------
(* MUTANT of MailboxOutbox: URB_LockOutbox refuses whenever the ISR is     *)
(* reading, whichever buffer (isr_idx # NONE instead of isr_idx = w): safe *)
(* but it refuses when it need not.                                        *)
(* Expected: LockBusyOnlyWhenReading.                                      *)
EXTENDS MailboxOutbox

MutLockCheck ==
    /\ appPc = "check"
    /\ appPc' = IF isrIdx # NONE THEN "idle" ELSE "write"
    /\ appByte' = 1
    /\ UNCHANGED <<buf, front, isrIdx, w, writes, isrPc, isrGot, released, isrSnap>>

MutNext == AppLockPick \/ MutLockCheck \/ AppWriteByte \/ AppRelease \/ IsrNext
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
