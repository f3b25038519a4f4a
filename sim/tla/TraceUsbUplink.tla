--------------------------- MODULE TraceUsbUplink ---------------------------
(***************************************************************************)
(* Trace validation of the pipelined USB uplink against UsbUplink.tla.     *)
(*                                                                         *)
(* The host library logs, for one USB bridge (UsbCore.trace, turned into  *)
(* the constant Trace by sim/urb_sim/tracecheck.py), each event           *)
(* with the 1-ms frame f of the host's clock it happened in:              *)
(*   [ev |-> "submit", f, id]        the application submitted request id  *)
(*                                   (ids count submissions from 1): Submit *)
(*   [ev |-> "write", f, ids]        the frame's bulk-OUT transfer carried  *)
(*                                   these requests, in order: UsbWrite     *)
(*   [ev |-> "read", f, seqs]        a bulk-IN transfer carried responses   *)
(*                                   with these sequence numbers: UsbRead   *)
(*   [ev |-> "callback", f, id, ok]  the callback of request id ran, ok    *)
(*                                   when it succeeded: Callback            *)
(* Not logged: the bridge running a batch over its downlink               *)
(* (BridgeProcess), taken at the end of the frame it was written in; an   *)
(* empty write or read, which a host that has nothing in flight does not  *)
(* make (UsbWrite of an empty buffer, UsbRead of an empty previous        *)
(* buffer); and the frame boundary (Tick), taken when the next event is in *)
(* a later frame, once per frame in between.  So a busy host must write   *)
(* in every frame, every batch's responses must come back in the next     *)
(* frame and their callbacks run before it ends (Tick's premises), and a  *)
(* callback's latency is counted in real frames.  Accepted when a state   *)
(* matches every event (urb_sim/tracebatch.py prints every state's l - 1, *)
(* the number of events it matched).  Every invariant of                   *)
(* UsbUplink.tla is checked on the way (LatencyBound: three frames).      *)
(***************************************************************************)
EXTENDS UsbUplink

CONSTANT Trace     \* the logged events (from sim/urb_sim/tracecheck.py)

VARIABLES l,      \* index of the next logged event to match
          frame   \* the frame the specification is in (host frames, from 0)

tvars == <<vars, l, frame>>

TraceInit == Init /\ l = 1 /\ frame = 0

(* The next event happens in the current frame. *)
Now == l <= Len(Trace) /\ Trace[l].f = frame

MatchSubmit ==
    /\ Now /\ Trace[l].ev = "submit"
    /\ Submit
    /\ hostQ'[Len(hostQ')] = Trace[l].id
    /\ l' = l + 1 /\ UNCHANGED frame

MatchWrite ==
    /\ Now /\ Trace[l].ev = "write"
    /\ UsbWrite
    /\ rx' = Trace[l].ids
    /\ l' = l + 1 /\ UNCHANGED frame

MatchRead ==
    /\ Now /\ Trace[l].ev = "read"
    /\ UsbRead
    /\ [k \in DOMAIN txPrev |-> txPrev[k].seq] = Trace[l].seqs
    /\ l' = l + 1 /\ UNCHANGED frame

MatchCallback ==
    /\ Now /\ Trace[l].ev = "callback"
    /\ Trace[l].ok
    /\ Callback
    /\ Head(expect) = Trace[l].id
    /\ l' = l + 1 /\ UNCHANGED frame

(* The next event is in a later frame: this one ends.  The batch written  *)
(* in it is run, an idle host's empty write and read are made, and the    *)
(* frame boundary passes.                                                  *)
Later == l <= Len(Trace) /\ Trace[l].f > frame

HiddenProcess == Later /\ BridgeProcess /\ UNCHANGED <<l, frame>>

(* A host with nothing queued or in flight writes nothing; in the         *)
(* specification it wrote an empty batch, before the frame's first        *)
(* submission.                                                             *)
HiddenIdleWrite ==
    /\ l <= Len(Trace) /\ (Trace[l].ev = "submit" \/ Trace[l].f > frame)
    /\ hostQ = <<>> /\ expect = <<>>
    /\ UsbWrite
    /\ UNCHANGED <<l, frame>>

HiddenIdleRead == Later /\ txPrev = <<>> /\ UsbRead /\ UNCHANGED <<l, frame>>

HiddenTick == Later /\ Tick /\ frame' = frame + 1 /\ UNCHANGED l

TraceNext == MatchSubmit \/ MatchWrite \/ MatchRead \/ MatchCallback
             \/ HiddenProcess \/ HiddenIdleWrite \/ HiddenIdleRead \/ HiddenTick

=============================================================================
