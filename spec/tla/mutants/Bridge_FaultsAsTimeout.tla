------------------------ MODULE Bridge_FaultsAsTimeout ------------------------
(* MUTANT of Bridge: every downlink failure is reported as TIMEOUT, hiding *)
(* checksum errors and bus-clears.  Expected: ErrorNamesCause.             *)
EXTENDS MCBridge

MutEmit ==
    /\ queue # <<>> /\ Head(queue).status # "PENDING"
    /\ LET e == Head(queue) IN
         out' = Append(out, [id |-> e.id, seq |-> e.id % SeqMod, data |-> e.data,
                             status |-> IF e.status \in DownlinkFaults
                                          THEN "TIMEOUT" ELSE e.status])
    /\ queue' = Tail(queue)
    /\ UNCHANGED <<sent, applied, cause, full>>

MutNext == SubmitAndAdmit \/ Serve \/ MutEmit \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
