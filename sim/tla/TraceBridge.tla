----------------------------- MODULE TraceBridge -----------------------------
(***************************************************************************)
(* Trace validation of the bridge firmware against Bridge.tla, in the style *)
(* of the etcd-raft and CCF projects: a trace logged by the simulation      *)
(* (sim/urb_sim/tracecheck.py turns its "bridge" events into the constant *)
(* Trace) must be a behaviour of the specification.                       *)
(*                                                                         *)
(* Logged events, in order:                                                 *)
(*   [ev |-> "req", req |-> r]            a request frame reached the       *)
(*                                        firmware: SubmitAndAdmit of r     *)
(*   [ev |-> "resp", seq, status]         a response left the bridge: Emit *)
(* The downlink transaction (Serve) is not logged: it happens between the  *)
(* logged events, with the outcome the next "resp" event names.  The trace *)
(* is accepted when a state matches every event (urb_sim/tracebatch.py     *)
(* checks many traces in one run, and prints every state's l - 1), and TLC *)
(* then stops for want of steps.  Every invariant of Bridge.tla is checked on *)
(* the way, and a rejected trace says in the same run how far it matched.  *)
(*                                                                         *)
(* Two choices keep a run linear in the trace (1,051 states for 700 events *)
(* under I2C bit errors, 17,501 before).  Serve is taken only when the next *)
(* event is a response whose request is still pending, and with the status *)
(* that response names: the other orders and outcomes are dead ends, and   *)
(* any behaviour matching the trace can be reordered into this one, since  *)
(* Serve changes nothing that admission reads.  And the whole match is not *)
(* an invariant violation: TLC would print its 700-state counterexample,    *)
(* each state holding the trace's sequences, which took longer than the    *)
(* search.                                                                 *)
(***************************************************************************)
EXTENDS Bridge

CONSTANT Trace     \* the logged events (from sim/urb_sim/tracecheck.py)

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

(* The unlogged downlink transaction of the oldest request, just before    *)
(* its response, with the outcome the response names.                      *)
Hidden ==
    /\ l <= Len(Trace)
    /\ Trace[l].ev = "resp"
    /\ queue # <<>> /\ Head(queue).status = "PENDING"
    /\ Serve
    /\ queue'[1].status = Trace[l].status
    /\ UNCHANGED l

TraceNext == MatchReq \/ MatchResp \/ Hidden

TraceSpec == TraceInit /\ [][TraceNext]_tvars

=============================================================================
