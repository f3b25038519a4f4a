-------------------------- MODULE Bridge_BusyOffByOne --------------------------
(* MUTANT of Bridge: the "queue full" test is off by one and answers BUSY  *)
(* while a data slot is still free.  Expected: BusyOnlyWhenFull.           *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq
    /\ Len(InFlight) < HostWindow
    /\ \E r \in Requests :
         LET id == Len(sent) + 1
             st == IF AdmissionStatus(r) # "OK" THEN AdmissionStatus(r)
                   ELSE IF DataSlotsUsed >= QueueLen - 1 THEN "BUSY"
                   ELSE "PENDING"
         IN /\ sent' = Append(sent, <<r, id>>)
            /\ queue' = Append(queue, [id |-> id, status |-> st, data |-> NoData])
            /\ cause' = IF st = "PENDING" THEN cause ELSE [cause EXCEPT ![id] = st]
            /\ full' = IF AdmissionStatus(r) = "OK" /\ DataSlotsUsed >= QueueLen
                         THEN full \cup {id} ELSE full
    /\ UNCHANGED <<out, applied, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == MutSubmit \/ Serve \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
