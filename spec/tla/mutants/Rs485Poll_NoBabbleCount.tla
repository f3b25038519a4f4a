---------------------- MODULE Rs485Poll_NoBabbleCount ----------------------
(* MUTANT of Rs485Poll: bytes heard while nobody was polled are not counted: a babbler goes unnoticed. *)
(* Expected: BabbleCounted *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMid, SendEnd, Silence, BabbleStartWith({}, TRUE))]_vars
=============================================================================
