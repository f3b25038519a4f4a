----------------------- MODULE MailboxInbox_StaleFront -----------------------
(* MUTANT of MailboxInbox: URB_LockInbox keeps the buffer index of its     *)
(* previous call instead of loading front (a cached index).  Every safety  *)
(* property holds (the checks refuse the stale buffer), but once a newer   *)
(* message is in the other buffer every attempt fails and the lock returns *)
(* URB_BUSY for ever (the mutation run found it survived before           *)
(* LockSucceedsWhenQuiet).                                                 *)
(* Expected: LockSucceedsWhenQuiet.                                        *)
EXTENDS MailboxInbox

MutLoadFront ==
    /\ appPc = "idle"
    /\ appPc' = "claim"
    /\ UNCHANGED <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, a, tries,
                   appGot, committed, aborted, appSnap, callFails>>

MutNext == IsrNext \/ MutLoadFront \/ AppLockClaim \/ AppLockCheckIsr
           \/ AppLockCheckFront \/ AppLockUnclaim \/ AppReadByte \/ AppRelease
MutSpec == Init /\ [][MutNext]_vars
           /\ WF_vars(tries > 0 /\ MutLoadFront)
           /\ WF_vars(AppLockClaim) /\ WF_vars(AppLockCheckIsr) /\ WF_vars(AppLockCheckFront)
           /\ WF_vars(AppLockUnclaim) /\ WF_vars(AppRelease)
=============================================================================
