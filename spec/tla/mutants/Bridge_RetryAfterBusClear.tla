----------------------- MODULE Bridge_RetryAfterBusClear -----------------------
(* MUTANT of Bridge: after a bus-clear the bridge sends BUS_STUCK at once  *)
(* and keeps the request queued to retry it (a retransmission).            *)
(* Expected: AtMostOneResponse.                                            *)
EXTENDS MCBridge

MutServe ==
    \/ Serve
    \/ /\ HasPending
       /\ LET k == FirstPending
              id == queue[k].id
          IN /\ Req(id).addr \in Present /\ "BUS_STUCK" \in Faults
             /\ out' = Append(out, [id |-> id, seq |-> SeqOf(id),
                                    status |-> "BUS_STUCK", data |-> NoData])
             /\ cause' = [cause EXCEPT ![id] = "BUS_STUCK"]
       /\ UNCHANGED <<sent, queue, applied, full, hostFrom, lastMatch, timedOut, linkUp, forgotten,
                      starts>>

MutNext == SubmitAndAdmit \/ MutServe \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
