------------------------- MODULE Bridge_MatchByOrder -------------------------
(* MUTANT of Bridge: the host does not check the sequence number: it       *)
(* gives every response it receives to the oldest request in flight.  Once *)
(* a response is lost on the uplink, the next one is given to the request *)
(* whose response was lost.  Expected: NoSeqAliasing.                     *)
EXTENDS MCBridge

MutMatch(resp) ==
    /\ hostFrom <= Len(sent)
    /\ hostFrom' = hostFrom + 1
    /\ lastMatch' = [req |-> hostFrom, resp |-> resp.id]
    /\ timedOut' = timedOut \ {hostFrom}

MutEmit ==
    /\ queue # <<>> /\ Head(queue).status # "PENDING"
    /\ LET e == Head(queue)
           resp == [id |-> e.id, seq |-> SeqOf(e.id), status |-> e.status, data |-> e.data]
       IN /\ out' = Append(out, resp)
          /\ MutMatch(resp) \/ UNCHANGED hostVars
    /\ queue' = Tail(queue)
    /\ UNCHANGED <<sent, applied, cause, full, linkUp, forgotten, starts>>

MutNext == SubmitAndAdmit \/ Serve \/ MutEmit \/ HostTimeout \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
