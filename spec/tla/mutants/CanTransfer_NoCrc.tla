---------------------- MODULE CanTransfer_NoCrc ----------------------
(* MUTANT of CanTransfer: a multi-frame transfer is delivered without its CRC: a lost middle frame realigns the toggle bit and a transfer missing a frame is delivered. *)
(* Expected: DeliveredIntact *)
EXTENDS MCCanTransfer

MutReceive(s, f) == ReceiveWith(s, f, TRUE, TRUE, TRUE, FALSE)
MutSpec == Init /\ [][NextBy(MutReceive)]_vars
=============================================================================
