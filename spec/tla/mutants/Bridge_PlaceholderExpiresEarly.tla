-------------------- MODULE Bridge_PlaceholderExpiresEarly --------------------
(* MUTANT of Bridge: a timed-out request keeps its number as a placeholder *)
(* (HostTimeout), but its lifetime is shorter than the bridge's worst-case *)
(* answer time: HostExpire's premise (the bridge no longer holds it)       *)
(* dropped, as with a placeholder_ns below the firmware's bound.  The      *)
(* number is freed while the bridge still holds the request, and its late *)
(* response is matched to a newer request.  Expected: NoSeqAliasing.      *)
EXTENDS MCBridge

MutExpire ==
    /\ hostFrom <= Len(sent) /\ hostFrom \in timedOut
    /\ hostFrom' = hostFrom + 1
    /\ timedOut' = timedOut \ {hostFrom}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, linkUp, forgotten, starts>>

MutNext == SubmitAndAdmit \/ Serve \/ Emit \/ HostTimeout \/ MutExpire \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
