---------------------- MODULE Bridge_OrderSkipsLastPair ----------------------
(* MUTANT of Bridge: the one-quantifier form of ResponsesInRequestOrder    *)
(* stops a pair early, so the last two responses may leave out of order.   *)
(* Expected: ASSUME (MCBridge's FormsAgree is false).                      *)
EXTENDS MCBridge

InOrderSkipsLastPair(s) == \A k \in 1..Len(s) - 2 : s[k].id <= s[k + 1].id

ASSUME FormsAgree(DistinctIds, InOrderSkipsLastPair)
=============================================================================
