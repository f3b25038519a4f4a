---------------------------- MODULE MCRs485Poll ----------------------------
(* The model checked by TLC: nodes n1 and n3 on the line, the bridge polls *)
(* n1 (present) then n2 (absent), a babbler with two bursts.              *)
EXTENDS Rs485Poll
MCNodes == {"n1", "n3"}
MCPolls == <<"n1", "n2">>
=============================================================================
