---------------------- MODULE Rs485Poll_AnswerOthers ----------------------
(* MUTANT of Rs485Poll: a node answers frames addressed to another (URB_MUTANT_RS485_ANSWER_OTHERS): two nodes drive at once. *)
(* Expected: OneTalker *)
EXTENDS MCRs485Poll

OtherAnswer(m) ==
    /\ phase \in {"wait", "answer"} /\ m # Target /\ m \notin drivers /\ got # "none"
    /\ drivers' = drivers \cup {m}
    /\ UNCHANGED <<k, phase, cut, due, got, stored, storesOf, garbled, from, result, babbleLeft, babbledIdle, heard, reported>>
MutSpec == Init /\ [][Next \/ \E m \in Nodes : OtherAnswer(m)]_vars
=============================================================================
