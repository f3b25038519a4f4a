--------------------- MODULE Bridge_PlaceholderNeverExpires ---------------------
(* MUTANT of Bridge: placeholders without a lifetime.  A timed-out request *)
(* keeps its number and window slot until a response releases it (its    *)
(* own late one, or a later request's), never because time passed.  A     *)
(* bridge that resets forgets the requests it holds and never answers     *)
(* them: once the host has timed them out, a window full of their         *)
(* placeholders stops it from sending anything else, and nothing is left *)
(* to answer (the host's poll finds nothing to do, forever).  On a        *)
(* lossless uplink, without reconnects.  Expected: EveryRequestReleased    *)
(* (liveness).                                                             *)
EXTENDS MCBridge

HostPolls == UNCHANGED vars

MutNext == SubmitAndAdmit \/ Serve \/ Emit \/ HostTimeout \/ BridgeReset \/ Done \/ HostPolls
MutSpec == Init /\ [][MutNext]_vars /\ WF_vars(Serve) /\ WF_vars(Emit) /\ WF_vars(HostTimeout)
=============================================================================
