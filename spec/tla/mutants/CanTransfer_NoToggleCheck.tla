---------------------- MODULE CanTransfer_NoToggleCheck ----------------------
(* MUTANT of CanTransfer: the receiver does not check the toggle bit (URB_MUTANT_CAN_NO_TOGGLE_CHECK): a frame taken twice (an end-of-frame error) joins the reassembly twice. *)
(* Expected: NoRepeatedFrame *)
EXTENDS MCCanTransfer

MutReceive(s, f) == ReceiveWith(s, f, FALSE, TRUE, TRUE, TRUE)
MutSpec == Init /\ [][NextBy(MutReceive)]_vars
=============================================================================
