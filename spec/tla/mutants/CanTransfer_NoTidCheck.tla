---------------------- MODULE CanTransfer_NoTidCheck ----------------------
(* MUTANT of CanTransfer: a continuation frame's transfer id is not compared: after a bus-off cut a transfer and the next one's start frame was lost, that transfer's second frame continues the old reassembly. *)
(* Expected: NoMixedTransfers *)
EXTENDS MCCanTransfer

MutReceive(s, f) == ReceiveWith(s, f, TRUE, FALSE, TRUE, TRUE)
MutSpec == Init /\ [][NextBy(MutReceive)]_vars
=============================================================================
