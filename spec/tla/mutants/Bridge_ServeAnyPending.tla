------------------------ MODULE Bridge_ServeAnyPending ------------------------
(* MUTANT of Bridge: the downlink serves ANY pending request, not the      *)
(* oldest, so two writes to one inbox can land in reverse order.  The ring *)
(* still sends the responses in arrival order, so every other invariant    *)
(* holds (before ServedInArrivalOrder this bridge passed them all).        *)
(* Expected: ServedInArrivalOrder.                                         *)
EXTENDS MCBridge

MutServe ==
    \E k \in DOMAIN queue :
       /\ queue[k].status = "PENDING"
       /\ LET id == queue[k].id
              r == Req(id)
          IN \E st \in IF r.addr \notin Present THEN {"NO_NODE"}
                       ELSE {"OK"} \cup (Faults \ (IF r.op = "read"
                                                     THEN {"NODE_BUSY"} ELSE {})) :
               /\ queue' = [queue EXCEPT ![k] =
                      [id |-> id, status |-> st,
                       data |-> IF st = "OK" /\ r.op = "read"
                                  THEN Outbox(r.addr, r.box) ELSE NoData]]
               /\ applied' = IF st = "OK" /\ r.op = "write"
                               THEN applied \cup {id} ELSE applied
               /\ cause' = [cause EXCEPT ![id] = st]
       /\ UNCHANGED <<sent, out, full, linkUp, forgotten, starts>> /\ UNCHANGED hostVars

MutNext == SubmitAndAdmit \/ MutServe \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
