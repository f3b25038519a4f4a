---------------------- MODULE CanTransfer_NoDedup ----------------------
(* MUTANT of CanTransfer: no duplicate filter (URB_MUTANT_CAN_NO_DEDUP): a single-frame transfer taken twice is delivered twice. *)
(* Expected: AtMostOnce *)
EXTENDS MCCanTransfer

MutReceive(s, f) == ReceiveWith(s, f, TRUE, TRUE, FALSE, TRUE)
MutSpec == Init /\ [][NextBy(MutReceive)]_vars
=============================================================================
