-------------------- MODULE Bridge_RestartWithoutHandover --------------------
(* MUTANT of Bridge: a new host process without the handover (the host     *)
(* library before PortHandover / MatchingCore.hand_over).  After the       *)
(* previous process ended (HostLinkLost) a new one opens the uplink at    *)
(* once, numbers its requests from 1 again and starts with an empty       *)
(* in-flight list, while the bridge may still hold requests of the old    *)
(* process: a late answer to one of them echoes the number of a new       *)
(* request in flight and is matched to it, on a lossless uplink.           *)
(* Expected: NoSeqAliasing.                                                *)
EXTENDS MCBridge

MutRestart ==
    /\ ~linkUp
    /\ linkUp' = TRUE
    /\ hostFrom' = Len(sent) + 1
    /\ timedOut' = {}
    /\ starts' = starts \cup {Len(sent) + 1}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, forgotten>>

MutNext == ReconnectNext \/ MutRestart
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
