-------------------- MODULE MailboxInbox_ReleaseKeepsClaim --------------------
(* MUTANT of MailboxInbox: URB_ReleaseInbox ends the read but keeps the    *)
(* claim (app_idx is not reset).  Every safety invariant of the first      *)
(* version still holds; but the ISR now NACKs every write to that buffer  *)
(* for as long as the application does not lock again.                    *)
(* Expected: ClaimReturned.                                                *)
EXTENDS MailboxInbox

MutRelease ==
    /\ appPc = "read"
    /\ appPc' = "idle" /\ appGot' = <<>>
    /\ UNCHANGED <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, a, tries,
                   committed, aborted, appSnap, callFails>>

MutNext == IsrNext \/ AppLockLoadFront \/ AppLockClaim \/ AppLockCheckIsr
           \/ AppLockCheckFront \/ AppLockUnclaim \/ AppReadByte \/ MutRelease
MutSpec == Init /\ [][MutNext]_vars
           /\ WF_vars(tries > 0 /\ AppLockLoadFront)
           /\ WF_vars(AppLockClaim) /\ WF_vars(AppLockCheckIsr) /\ WF_vars(AppLockCheckFront)
           /\ WF_vars(AppLockUnclaim) /\ WF_vars(MutRelease)
=============================================================================
