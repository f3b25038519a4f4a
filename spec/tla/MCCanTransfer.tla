--------------------------- MODULE MCCanTransfer ---------------------------
(* The model checked by TLC: two sessions whose transfers interleave, one  *)
(* with a 4-frame transfer (a lost middle frame realigns the toggle bit and *)
(* only the CRC refuses it) then a single frame, the other two 2-frame     *)
(* transfers (after a bus-off and a lost start, only the transfer id keeps *)
(* their frames apart).                                                     *)
EXTENDS CanTransfer
MCSenders == {"a", "b"}
MCLens == [s \in MCSenders |-> IF s = "a" THEN <<4, 1>> ELSE <<2, 2>>]

(* Reachability witnesses (spec/tla/mutants/CanTransfer_Reach.cfg and the *)
(* like): each is violated in some reachable state, which TLC must show.    *)
NotMultiFrameDone == \A s \in Senders : \A x \in Xfers(s) : Lens[s][x] > 1 => count[s][x] = 0
NotToggleRejected == ev # "toggle"
NotDuplicateDropped == ev # "dup"
NotCrcRejected == ev # "crc"
NotInterleaved == ~(rx["a"].active /\ rx["b"].active)
NotBusOffRecovered == ~recovered
=============================================================================
