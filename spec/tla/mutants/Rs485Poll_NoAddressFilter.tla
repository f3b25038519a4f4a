--------------------- MODULE Rs485Poll_NoAddressFilter ---------------------
(* MUTANT of Rs485Poll: a node's address filter is broken: it answers a poll of an absent address when the line falls silent (one talker at a time, so OneTalker holds; the bridge reports the answer's outcome for a node it did not poll). *)
(* Expected: OnlyPolledNodeTalks *)
EXTENDS MCRs485Poll

AnswerAbsent(m) ==
    /\ phase = "wait" /\ due = NOBODY /\ drivers = {} /\ Target \notin Nodes
    /\ drivers' = {m} /\ from' = m /\ phase' = "answer"
    /\ UNCHANGED <<k, cut, due, got, stored, storesOf, garbled, result, babbleLeft, babbledIdle, heard, reported>>
MutSpec == Init /\ [][Next \/ \E m \in Nodes : AnswerAbsent(m)]_vars
=============================================================================
