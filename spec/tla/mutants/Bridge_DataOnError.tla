-------------------------- MODULE Bridge_DataOnError --------------------------
(* MUTANT of Bridge: a failed read still ships the (stale) contents of the *)
(* downlink buffer as if it were the mailbox's data.                       *)
(* Expected: ResponseMatchesRequest.                                       *)
EXTENDS MCBridge

MutServe ==
    /\ HasPending
    /\ LET k == FirstPending
           id == queue[k].id
           r == Req(id)
       IN \E st \in IF r.addr \notin Present THEN {"NO_NODE"}
                    ELSE {"OK"} \cup (Faults \ (IF r.op = "read"
                                                  THEN {"NODE_BUSY"} ELSE {})) :
            /\ queue' = [queue EXCEPT ![k] =
                   [id |-> id, status |-> st,
                    data |-> IF r.op = "read" THEN Outbox(r.addr, r.box) ELSE NoData]]
            /\ applied' = IF st = "OK" /\ r.op = "write"
                            THEN applied \cup {id} ELSE applied
            /\ cause' = [cause EXCEPT ![id] = st]
    /\ UNCHANGED <<sent, out, full, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == SubmitAndAdmit \/ MutServe \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
