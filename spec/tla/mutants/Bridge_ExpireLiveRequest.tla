-------------------- MODULE Bridge_ExpireLiveRequest --------------------
(* MUTANT of Bridge: the host releases its oldest request once the bridge  *)
(* no longer holds it, whether or not it timed out: HostExpire's guard    *)
(* hostFrom \in timedOut dropped.  A request whose response was lost on   *)
(* the uplink leaves the in-flight list without completing (no callback). *)
(* It passed every property of Bridge until HostReleasesOnlyCompleted      *)
(* (issue #37's mutation run, Bridge/HostExpire/drop-guard#3).             *)
(* Expected: HostReleasesOnlyCompleted.                                    *)
EXTENDS MCBridge

MutExpire ==
    /\ hostFrom <= Len(sent)
    /\ hostFrom \notin Ids(queue)
    /\ hostFrom' = hostFrom + 1
    /\ timedOut' = timedOut \ {hostFrom}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, linkUp, forgotten, starts>>

MutNext == SubmitAndAdmit \/ Serve \/ Emit \/ HostTimeout \/ MutExpire \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
