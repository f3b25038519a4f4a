------------------------ MODULE Bridge_NodeBusyOnRead ------------------------
(* MUTANT of Bridge: the downlink's NACK outcome is attached to the wrong  *)
(* operation: a read can end NODE_BUSY, a write cannot (the mutation run   *)
(* found this survived before NodeBusyOnlyForWrites).                      *)
(* Expected: NodeBusyOnlyForWrites.                                        *)
EXTENDS MCBridge

MutServe ==
    \E k \in DOMAIN queue :
       /\ OldestPending(k)
       /\ LET id == queue[k].id
              r == Req(id)
          IN \E st \in IF r.addr \notin Present THEN {"NO_NODE"}
                       ELSE {"OK"} \cup (Faults \ (IF r.op # "read"
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
