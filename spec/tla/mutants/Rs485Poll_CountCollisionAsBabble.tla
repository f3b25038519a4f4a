------------------ MODULE Rs485Poll_CountCollisionAsBabble ------------------
(* MUTANT of Rs485Poll: the bridge counts every byte another driver sends as babble, also during its own poll (a collision with its request, a garbled answer): the babble count blames a babbler for a poll's traffic. *)
(* Expected: NoFalseBabble *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMid, SendEnd, Silence,
                               BabbleStartWith({"idle", "send", "wait", "answer", "drain", "done"}, TRUE))]_vars
=============================================================================
