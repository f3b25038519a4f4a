------------------------- MODULE CanTransfer_Reach -------------------------
(* REACHABILITY WITNESSES of MCCanTransfer: the model unchanged; each      *)
(* CanTransfer_Reach*.cfg checks one invariant saying an interesting state *)
(* is never reached, which TLC must refute (so the state is reached and    *)
(* the model's invariants are not checked on a model that never gets there).*)
(* Expected: NotMultiFrameDone   (a multi-frame transfer delivered)          *)
(* Expected: NotToggleRejected   (a repeated frame refused by its toggle bit) *)
(* Expected: NotDuplicateDropped (a repeated single-frame transfer ignored)   *)
(* Expected: NotCrcRejected      (a transfer missing a frame refused by the CRC) *)
(* Expected: NotInterleaved      (two sessions' transfers in progress at once) *)
(* Expected: NotBusOffRecovered  (a sender bus-off and back on the bus)       *)
EXTENDS MCCanTransfer
=============================================================================
