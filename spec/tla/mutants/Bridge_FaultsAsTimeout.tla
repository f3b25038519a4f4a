------------------------ MODULE Bridge_FaultsAsTimeout ------------------------
(* MUTANT of Bridge: every downlink failure is reported as TIMEOUT, hiding *)
(* checksum errors and bus-clears.  Expected: ErrorNamesCause.             *)
EXTENDS MCBridge

MutEmit ==
    /\ queue # <<>> /\ Head(queue).status # "PENDING"
    /\ LET e == Head(queue)
           resp == [id |-> e.id, seq |-> SeqOf(e.id), data |-> e.data,
                    status |-> IF e.status \in DownlinkFaults THEN "TIMEOUT" ELSE e.status]
       IN /\ out' = Append(out, resp)
          /\ HostReceives(resp)
    /\ queue' = Tail(queue)
    /\ UNCHANGED <<sent, applied, cause, full, linkUp, forgotten, starts>>

MutNext == SubmitAndAdmit \/ Serve \/ MutEmit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
