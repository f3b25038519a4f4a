---------------------------- MODULE MCRs485Poll ----------------------------
(* The model checked by TLC: nodes n1 and n3 on the line, the bridge polls *)
(* n1 (present) then n2 (absent), a babbler with two bursts.              *)
EXTENDS Rs485Poll
MCNodes == {"n1", "n3"}
MCPolls == <<"n1", "n2">>

(* Reachability witnesses (spec/tla/mutants/Rs485Poll_Reach*.cfg): each is *)
(* violated in some reachable state, which TLC must show.                  *)
Outcome(r) == \E i \in DOMAIN reported : reported[i].result = r
NotCollisionDetected == ~Outcome("BUS_STUCK")
NotSilentNode == ~Outcome("NO_NODE")
NotBabblerCounted == heard = 0
NotAnswerOk == ~Outcome("OK")
NotGarbledAnswer == ~Outcome("TIMEOUT")
NotNodeChecksum == ~Outcome("CHECKSUM")
=============================================================================
