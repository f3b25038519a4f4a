------------------------ MODULE Bridge_WindowWrapsSeq ------------------------
(* MUTANT of Bridge: the host's window is one larger than the sequence     *)
(* space (it sends while at most SeqMod requests are in flight, so SeqMod  *)
(* + 1 can be).  The oldest and the newest request in flight then carry   *)
(* the same sequence number; when the responses before the newest one are *)
(* lost, the newest one's response is matched to the oldest request.      *)
(* (A window of exactly SeqMod does not alias: SeqMod consecutive         *)
(* requests carry distinct numbers.)  Expected: NoSeqAliasing.            *)
EXTENDS MCBridge

MutSubmit ==
    /\ Len(sent) < MaxReq
    /\ Len(InFlight) <= SeqMod
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

MutNext == MutSubmit \/ Serve \/ Emit \/ HostTimeout \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
