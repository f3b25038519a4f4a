----------------------------- MODULE TraceOutbox -----------------------------
(***************************************************************************)
(* Trace validation of a node's outbox against MailboxOutbox.tla.          *)
(*                                                                         *)
(* The simulation logs, for outbox 1 of one probe node (its bytes all carry *)
(* the low byte of the write's update counter, so every byte read names    *)
(* the write it came from):                                                *)
(*   [ev |-> "release"]          URB_ReleaseOutbox: AppRelease              *)
(*   [ev |-> "begin"]            the bridge's read address matched:         *)
(*                               IsrReadBegin                               *)
(*   [ev |-> "byte", tag |-> k]  a data byte sent, from write k (0 = the    *)
(*                               zero-filled setup): IsrReadByte            *)
(*   [ev |-> "end"]              STOP: IsrReadEnd                           *)
(* The application's lock and byte stores (AppLockPick, AppLockCheck,       *)
(* AppWriteByte) are not logged: TLC places them wherever the trace allows. *)
(* Accepted when a state matches every event (urb_sim/tracebatch.py prints *)
(* every state's l - 1, the number of events it matched; hidden steps end  *)
(* with the trace, so TLC then stops). Every invariant of MailboxOutbox.tla *)
(* is checked along the way; a rejected trace says how far it matched.     *)
(***************************************************************************)
EXTENDS MailboxOutbox

CONSTANT Trace     \* the logged events (from sim/urb_sim/tracecheck.py)

VARIABLE l

tvars == <<vars, l>>

TraceInit == Init /\ l = 1

MatchRelease ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "release"
    /\ AppRelease
    /\ l' = l + 1

MatchBegin ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "begin"
    /\ IsrReadBegin
    /\ l' = l + 1

MatchByte ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "byte"
    /\ IsrReadByte
    /\ isrGot'[Len(isrGot')] = Trace[l].tag
    /\ l' = l + 1

MatchEnd ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "end"
    /\ IsrReadEnd
    /\ l' = l + 1

Hidden == l <= Len(Trace) /\ (AppLockPick \/ AppLockCheck \/ AppWriteByte) /\ UNCHANGED l

TraceNext == MatchRelease \/ MatchBegin \/ MatchByte \/ MatchEnd \/ Hidden

=============================================================================
