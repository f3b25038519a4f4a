------------------- MODULE Bridge_WindowSkipsPlaceholders -------------------
(* MUTANT of Bridge: the host keeps placeholders (their numbers reserved  *)
(* for matching) but its window counts only the live requests in flight.  *)
(* More than SeqMod requests can then be in flight, a placeholder and a   *)
(* newer request sharing a number; when the placeholder's response was    *)
(* lost, the newer request's response is taken for the placeholder's late *)
(* response (oldest first).  Expected: NoSeqAliasing.                     *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq
    /\ Len(InFlight) - Cardinality(timedOut) < HostWindow
    /\ \E r \in Requests :
         LET id == Len(sent) + 1
             st == IF AdmissionStatus(r) # "OK" THEN AdmissionStatus(r)
                   ELSE IF DataSlotsUsed >= QueueLen THEN "BUSY"
                   ELSE "PENDING"
         IN /\ sent' = Append(sent, <<r, id>>)
            /\ queue' = Append(queue, [id |-> id, status |-> st, data |-> NoData])
            /\ cause' = IF st = "PENDING" THEN cause ELSE [cause EXCEPT ![id] = st]
            /\ full' = IF AdmissionStatus(r) = "OK" /\ DataSlotsUsed >= QueueLen
                         THEN full \cup {id} ELSE full
    /\ UNCHANGED <<out, applied, hostFrom, lastMatch, timedOut, linkUp, forgotten, starts>>

MutNext == MutSubmit \/ Serve \/ Emit \/ HostTimeout \/ HostExpire \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
