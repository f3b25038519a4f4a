----------------------------- MODULE TraceBridge -----------------------------
(***************************************************************************)
(* Trace validation of the bridge firmware against Bridge.tla, in the style *)
(* of the etcd-raft and CCF projects: a trace logged by the simulation      *)
(* (sim/urb_sim/tracecheck.py turns its "bridge" events into the module    *)
(* TraceBridgeData) must be a behaviour of the specification.               *)
(*                                                                         *)
(* Logged events, in order:                                                 *)
(*   [ev |-> "req", req |-> r]            a request frame reached the       *)
(*                                        firmware: SubmitAndAdmit of r     *)
(*   [ev |-> "resp", seq, status]         a response left the bridge: Emit *)
(* The downlink transaction (Serve) is not logged: it may happen between    *)
(* any two logged events, with any outcome the specification allows; the   *)
(* later "resp" event decides which. The trace is accepted when TLC reaches *)
(* a state that has matched every event: the invariant TraceNotMatched is   *)
(* then violated, which is the expected result. Along the way every         *)
(* invariant of Bridge.tla is checked on the trace's states, and            *)
(* MatchedSoFar prints each new longest matched prefix, so a rejected trace *)
(* says in the same run how far it matched.                                 *)
(***************************************************************************)
EXTENDS Bridge, TraceBridgeData, TLC

VARIABLE l          \* index of the next logged event to match

tvars == <<vars, l>>

TraceInit == Init /\ l = 1

(* A logged request: the firmware admitted exactly this request. *)
MatchReq ==
    /\ l <= Len(Trace)
    /\ Trace[l].ev = "req"
    /\ SubmitAndAdmit
    /\ sent'[Len(sent')][1] = Trace[l].req
    /\ l' = l + 1

(* A logged response: the oldest final response left with this sequence  *)
(* number and status.                                                      *)
MatchResp ==
    /\ l <= Len(Trace)
    /\ Trace[l].ev = "resp"
    /\ Emit
    /\ out'[Len(out')].seq = Trace[l].seq
    /\ out'[Len(out')].status = Trace[l].status
    /\ l' = l + 1

(* The unlogged downlink transaction. *)
Hidden == Serve /\ UNCHANGED l

TraceNext == MatchReq \/ MatchResp \/ Hidden

TraceSpec == TraceInit /\ [][TraceNext]_tvars

(* Violated exactly when the whole trace has been matched. *)
TraceNotMatched == l <= Len(Trace)

(* Not a property (always TRUE): TLC register 1 holds the longest prefix  *)
(* matched in any state seen so far, and each new one is printed as       *)
(* <<"matched", n>> (tracecheck.py reads the last).                        *)
ASSUME TLCSet(1, 0)
MatchedSoFar ==
    IF l - 1 > TLCGet(1) THEN TLCSet(1, l - 1) /\ PrintT(<<"matched", l - 1>>) ELSE TRUE
=============================================================================
