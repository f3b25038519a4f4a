------------------- MODULE Bridge_ReconnectClearsPlaceholders -------------------
(* MUTANT of Bridge: a naive reconnect.  When the uplink is reopened the   *)
(* host starts with an empty in-flight list (a new ResponseMatcher in     *)
(* reset()), forgetting the placeholders that close or loss left; its     *)
(* numbering goes on.  Reopening the port does not reset the bridge: it   *)
(* still holds the requests sent before, the window lets a full window of *)
(* new ones go out on top of them, and a late answer to an old request    *)
(* echoes the number of a new one in flight and is matched to it, on a    *)
(* lossless uplink.  Expected: NoSeqAliasing.                              *)
EXTENDS MCBridge

MutReopen ==
    /\ ~linkUp
    /\ linkUp' = TRUE
    /\ hostFrom' = Len(sent) + 1
    /\ timedOut' = {}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, forgotten, starts>>

MutNext == Next \/ HostLinkLost \/ MutReopen
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
