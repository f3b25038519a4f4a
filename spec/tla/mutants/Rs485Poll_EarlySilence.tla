---------------------- MODULE Rs485Poll_EarlySilence ----------------------
(* MUTANT of Rs485Poll: the silence timeout is shorter than t3.5 + the turnaround (URB_MUTANT_RS485_SILENCE_AS_TIMEOUT is its TIMEOUT twin): NO_NODE for a node that answers and stores later. *)
(* Expected: StatusTruthful *)
EXTENDS MCRs485Poll

MutSpec == Init /\ [][NextWith(CollideMid, SendEnd, SilenceWith(TRUE), BabbleStart)]_vars
=============================================================================
