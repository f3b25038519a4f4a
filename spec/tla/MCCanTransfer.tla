--------------------------- MODULE MCCanTransfer ---------------------------
(* The model checked by TLC: two sessions whose transfers interleave, one  *)
(* with a 4-frame transfer (a lost middle frame realigns the toggle bit and *)
(* only the CRC refuses it) then a single frame, the other two 2-frame     *)
(* transfers (after a bus-off and a lost start, only the transfer id keeps *)
(* their frames apart).                                                     *)
EXTENDS CanTransfer
MCSenders == {"a", "b"}
MCLens == [s \in MCSenders |-> IF s = "a" THEN <<4, 1>> ELSE <<2, 2>>]

=============================================================================
