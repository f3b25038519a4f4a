---------------------- MODULE Bridge_TimeoutWhileQueued ----------------------
(* MUTANT of Bridge: the host times out a request the bridge still holds  *)
(* (the premise of HostTimeout dropped: a bridge slower than the host's   *)
(* timeout).  The timed-out request leaves the host's window while it is  *)
(* still queued in the bridge, so more than SeqMod requests can be        *)
(* outstanding; its late response echoes the sequence number of a newer  *)
(* request in flight and is matched to it.  Expected: NoSeqAliasing.      *)
EXTENDS MCBridge

MutTimeout ==
    /\ hostFrom <= Len(sent)
    /\ hostFrom' = hostFrom + 1
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch>>

MutNext == SubmitAndAdmit \/ Serve \/ Emit \/ MutTimeout \/ Done
MutSpec == Init /\ [][MutNext]_vars
=============================================================================
