--------------------- MODULE Rs485Poll_SentIgnoresBreak ---------------------
(* MUTANT of Rs485Poll: the bridge ignores a break of its request's frame after the last byte (the firmware before issue #39's fix: SENT ignored the receiver's EV_BROKEN), takes the babbler's frame end for its request's and reports the node's silence NO_NODE for a request no node received. fw_rs485_master's seeded bug sent-ignores-break is its C twin. *)
(* Expected: NoNodeOnlyWhole *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMid, SendEnd, Silence, BabbleStartWith({"idle", "done"}, FALSE))]_vars
=============================================================================
