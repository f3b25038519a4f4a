------------------------ MODULE Bridge_TimeoutFreesSeq ------------------------
(* MUTANT of Bridge: the host library before the fix.  A request that     *)
(* times out leaves the host's in-flight list at once (no placeholder),   *)
(* freeing its window slot and its sequence number while the bridge may   *)
(* still hold it (a bridge slower than the host's timeout).  More than    *)
(* SeqMod requests can then be outstanding; the late response echoes the  *)
(* number of a newer request in flight and is matched to it.              *)
(* Expected: NoSeqAliasing.                                                *)
EXTENDS MCBridge

MutTimeout ==
    /\ hostFrom <= Len(sent)
    /\ hostFrom' = hostFrom + 1
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, timedOut, linkUp, forgotten,
                   starts>>

MutNext == SubmitAndAdmit \/ Serve \/ Emit \/ MutTimeout \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
