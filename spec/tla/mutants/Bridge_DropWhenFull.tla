-------------------------- MODULE Bridge_DropWhenFull --------------------------
(* MUTANT of Bridge: a request that finds every data slot taken is thrown  *)
(* away without a response.  Expected: NoSilentDrop.                       *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq /\ Len(InFlight) < HostWindow
    /\ \E r \in Requests :
         LET id == Len(sent) + 1 IN
         /\ sent' = Append(sent, <<r, id>>)
         /\ IF AdmissionStatus(r) = "OK" /\ DataSlotsUsed >= QueueLen
              THEN UNCHANGED <<queue, cause, full>>
              ELSE /\ queue' = Append(queue, [id |-> id, data |-> NoData,
                        status |-> IF AdmissionStatus(r) # "OK"
                                     THEN AdmissionStatus(r) ELSE "PENDING"])
                   /\ cause' = IF AdmissionStatus(r) # "OK"
                                 THEN [cause EXCEPT ![id] = AdmissionStatus(r)] ELSE cause
                   /\ UNCHANGED full
    /\ UNCHANGED <<out, applied, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == MutSubmit \/ Serve \/ Emit \/ Done \/ (Len(sent) = MaxReq /\ UNCHANGED vars)
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
