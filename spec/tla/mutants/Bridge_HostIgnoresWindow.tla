------------------------ MODULE Bridge_HostIgnoresWindow ------------------------
(* MUTANT of Bridge: the host does not bound its outstanding requests, so  *)
(* the bridge's response ring overflows.  Expected: BoundedMemory.         *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq
    /\ \E r \in Requests :
         LET id == Len(sent) + 1
             st == IF AdmissionStatus(r) # "OK" THEN AdmissionStatus(r)
                   ELSE IF DataSlotsUsed >= QueueLen THEN "BUSY"
                   ELSE "PENDING"
         IN /\ sent' = Append(sent, <<r, id>>)
            /\ queue' = Append(queue, [id |-> id, status |-> st, data |-> NoData])
            /\ cause' = IF st = "PENDING" THEN cause ELSE [cause EXCEPT ![id] = st]
            /\ full' = IF st = "BUSY" THEN full \cup {id} ELSE full
    /\ UNCHANGED <<out, applied, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == MutSubmit \/ Serve \/ Emit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
