--------------------- MODULE Bridge_MailboxLimitOffByOne ---------------------
(* MUTANT of Bridge: admission accepts mailbox 8 (0..8 instead of 0..7).   *)
(* The model's requests use mailboxes 1 and 9 only, so no behaviour shows  *)
(* it; MCBridge's HeaderLimitsAgree does.                                  *)
(* Expected: ASSUME (MCBridge's HeaderLimitsAgree is false).               *)
EXTENDS MCBridge

MutAdmissionStatus(r) ==
    IF r.box \notin 0..8 \/ r.len \notin 1..32 THEN "BAD_REQUEST"
    ELSE IF r.addr \in Present /\ r.len # Size[r.addr][r.box]
         THEN "SIZE_MISMATCH" ELSE "OK"

ASSUME HeaderLimitsAgree(MutAdmissionStatus)
=============================================================================
