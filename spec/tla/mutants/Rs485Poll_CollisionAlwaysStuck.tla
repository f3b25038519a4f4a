---------------------- MODULE Rs485Poll_CollisionAlwaysStuck ----------------------
(* MUTANT of Rs485Poll: a collision on the request's last byte is reported BUS_STUCK like one that cut it, though the node may have taken the frame and stored it. *)
(* Expected: StatusTruthful *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMid, SendEndWith(TRUE), Silence, BabbleStart)]_vars
=============================================================================
