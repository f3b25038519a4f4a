----------------------- MODULE Bridge_WedgeAfterBusStuck -----------------------
(* MUTANT of Bridge: after a stuck bus the bridge reports BUS_STUCK but    *)
(* never performs the bus-clear: it serves nothing afterwards (it keeps    *)
(* polling the bus lines, a stuttering step).                              *)
(* Expected: EveryRequestAnswered (liveness).                              *)
EXTENDS MCBridge

Wedged == \E i \in 1..MaxReq : cause[i] = "BUS_STUCK"
MutServe == ~Wedged /\ Serve
PollBus == Wedged /\ UNCHANGED vars

MutNext == SubmitAndAdmit \/ MutServe \/ Emit \/ Done \/ PollBus
MutSpec == Init /\ [][MutNext]_vars /\ WF_vars(MutServe) /\ WF_vars(Emit)
=============================================================================
