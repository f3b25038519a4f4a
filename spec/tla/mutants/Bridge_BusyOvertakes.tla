------------------------- MODULE Bridge_BusyOvertakes -------------------------
(* MUTANT of Bridge: BUSY is sent on the uplink at admission, ahead of the *)
(* earlier requests still queued.  Expected: ResponsesInRequestOrder.       *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq
    /\ Len(InFlight) < HostWindow
    /\ \E r \in Requests :
         LET id == Len(sent) + 1
             st == IF AdmissionStatus(r) # "OK" THEN AdmissionStatus(r)
                   ELSE IF DataSlotsUsed >= QueueLen THEN "BUSY"
                   ELSE "PENDING"
         IN /\ sent' = Append(sent, <<r, id>>)
            /\ IF st = "BUSY"
                 THEN /\ out' = Append(out, [id |-> id, seq |-> SeqOf(id),
                                             status |-> "BUSY", data |-> NoData])
                      /\ UNCHANGED queue
                 ELSE /\ queue' = Append(queue, [id |-> id, status |-> st, data |-> NoData])
                      /\ UNCHANGED out
            /\ cause' = IF st = "PENDING" THEN cause ELSE [cause EXCEPT ![id] = st]
            /\ full' = IF st = "BUSY" THEN full \cup {id} ELSE full
    /\ UNCHANGED <<applied, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == MutSubmit \/ Serve \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
