-------------------------- MODULE Rs485Poll_Reach --------------------------
(* REACHABILITY WITNESSES of MCRs485Poll: the model unchanged; each        *)
(* Rs485Poll_Reach*.cfg checks one invariant saying an outcome is never    *)
(* reached, which TLC must refute.                                         *)
(* Expected: NotCollisionDetected (a collision cut a request: BUS_STUCK)   *)
(* Expected: NotSilentNode        (the absent node: NO_NODE)               *)
(* Expected: NotBabblerCounted    (bytes heard while nobody was polled)    *)
(* Expected: NotAnswerOk          (a poll answered OK)                     *)
(* Expected: NotGarbledAnswer     (an answer garbled by the babbler: TIMEOUT) *)
(* Expected: NotNodeChecksum      (a request corrupted on its last byte: the node's CHECKSUM) *)
EXTENDS MCRs485Poll
=============================================================================
