------------------------ MODULE Bridge_AckBeforeChecksum ------------------------
(* MUTANT of Bridge: a write is reported OK once its bytes were ACKed,     *)
(* although the node discarded it for a checksum mismatch.                 *)
(* Expected: WriteStatusTruthful.                                          *)
EXTENDS MCBridge

MutServe ==
    \/ Serve
    \/ /\ HasPending
       /\ LET k == FirstPending
              id == queue[k].id
          IN /\ Req(id).op = "write" /\ Req(id).addr \in Present
             /\ "CHECKSUM" \in Faults
             /\ queue' = [queue EXCEPT ![k] = [id |-> id, status |-> "OK", data |-> NoData]]
             /\ cause' = [cause EXCEPT ![id] = "CHECKSUM"]
       /\ UNCHANGED <<sent, out, applied, full, hostFrom, lastMatch, timedOut, linkUp, forgotten,
                      starts>>

MutNext == SubmitAndAdmit \/ MutServe \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
