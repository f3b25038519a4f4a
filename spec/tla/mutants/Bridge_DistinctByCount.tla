----------------------- MODULE Bridge_DistinctByCount -----------------------
(* MUTANT of Bridge: the one-quantifier form of AtMostOneResponse compares *)
(* the number of distinct ids with <= instead of =, which always holds, so *)
(* a request answered twice goes unnoticed.                                *)
(* Expected: ASSUME (MCBridge's FormsAgree is false).                      *)
EXTENDS MCBridge

DistinctByCount(s) == Cardinality(Ids(s)) <= Len(s)

ASSUME FormsAgree(DistinctByCount, IdsInOrder)
=============================================================================
