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
(* Accepted when a state matches every event: MatchedSoFar prints each new *)
(* longest matched prefix, the whole trace's length last (hidden steps end *)
(* with the trace, so TLC then stops). Every invariant of MailboxOutbox.tla *)
(* is checked along the way; a rejected trace says how far it matched.     *)
(***************************************************************************)
EXTENDS MailboxOutbox, TraceOutboxData, TLC

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

(* Not a property (always TRUE): TLC register 1 holds the longest prefix  *)
(* matched in any state seen so far, and each new one is printed as       *)
(* <<"matched", n>> (tracecheck.py reads the last).                        *)
ASSUME TLCSet(1, 0)
MatchedSoFar ==
    IF l - 1 > TLCGet(1) THEN TLCSet(1, l - 1) /\ PrintT(<<"matched", l - 1>>) ELSE TRUE
=============================================================================
