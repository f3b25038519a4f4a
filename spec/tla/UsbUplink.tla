------------------------------- MODULE UsbUplink -------------------------------
(***************************************************************************)
(* The pipelined USB uplink of one bridge (paper Sec. V-C, Fig. 9).         *)
(*                                                                         *)
(* Time is a sequence of 1-ms frames (the 1-kHz OS tick = the USB frame).  *)
(* In every frame, in any order and interleaved with the application's    *)
(* submissions:                                                            *)
(*   UsbWrite       the USBManager write thread wakes on the tick and      *)
(*                  sends ONE bulk-OUT transfer holding up to MaxBatch of  *)
(*                  the buffered requests (batch n), with never more than  *)
(*                  Window requests in flight; the rest stay queued on the *)
(*                  host for the next frame, never dropped;                *)
(*   BridgeProcess  the bridge runs batch n over the downlink and stores   *)
(*                  its responses in its CURRENT response buffer;          *)
(*   UsbRead        the bulk-IN read issued by batch n-1's write callback  *)
(*                  fetches the bridge's PREVIOUS response buffer (n-1);   *)
(*   Callback       the read thread invokes callbacks in order, matching   *)
(*                  each response by its sequence number to the oldest    *)
(*                  outstanding request that carries it (ResponseMatcher). *)
(* So write n and read n-1 share a frame: the bridge double-buffers its    *)
(* responses.  Tick ends the frame; real-time premises: every thread runs  *)
(* once per frame and a batch fits the downlink in one frame (the         *)
(* downlink itself is Bridge.tla's subject).  Latency is counted in frames *)
(* touched: submitted in frame s, callback in frame c => c - s + 1.        *)
(***************************************************************************)
EXTENDS Naturals, Sequences, FiniteSets

CONSTANTS
    MaxBatch,    \* requests per bulk-OUT transfer
    MaxSubmit,   \* requests the application may submit between two writes
    MaxReq,      \* requests submitted in a behaviour
    Window,      \* host: most requests in flight (sent, not called back);
                 \*   UsbCore.window = min(BridgeInfo.fifo_depth, 15)
    MaxLatency,  \* bound on callback latency in frames (paper: 3 ms)
    SeqMod       \* sequence numbers 0..SeqMod - 1 (the uplink's 4 bits: 16)

ASSUME MaxBatch \in Nat \ {0} /\ MaxSubmit \in Nat \ {0} /\ MaxReq \in Nat
       /\ SeqMod \in Nat \ {0}
       /\ Window \in 1..SeqMod - 1 /\ MaxLatency \in Nat   \* < SeqMod: no aliasing
Ids == 1..MaxReq
AgeCap == MaxLatency + MaxReq + 1 \* ages saturate here (keeps the model finite)

VARIABLES
    nextId,    \* requests submitted so far (ids 1..nextId)
    budget,    \* submissions since the last UsbWrite
    hostQ,     \* host: requests buffered by USBManager, not yet sent
    expect,    \* host: ids sent and not yet called back, in send order
    rx,        \* bridge: batch received this frame, not yet processed
    txPrev,    \* bridge: responses of batch n-1 (read in this frame)
    txCur,     \* bridge: responses of batch n (being produced)
    hostRx,    \* host: responses read, awaiting their callback
    done,      \* ids whose callback has run
    cbLog,     \* callback log: [req (expected id), resp (response's id, 0:
               \*   completed without one, as lost)]
    age,       \* age[id]: frames since submission, frozen at callback
    deferred,  \* deferred[id]: writes that left id queued (batch full)
    wrote, readDone  \* this frame's write / read has happened

vars == <<nextId, budget, hostQ, expect, rx, txPrev, txCur, hostRx, done,
          cbLog, age, deferred, wrote, readDone>>

Resp == [id: Ids, seq: 0..SeqMod - 1]

TypeOK ==
    /\ nextId \in 0..MaxReq /\ budget \in 0..MaxSubmit
    /\ hostQ \in Seq(Ids) /\ expect \in Seq(Ids) /\ rx \in Seq(Ids)
    /\ Len(hostQ) <= MaxReq /\ Len(expect) <= MaxReq /\ Len(rx) <= MaxBatch
    /\ txPrev \in Seq(Resp) /\ txCur \in Seq(Resp) /\ hostRx \in Seq(Resp)
    \* the firmware's response buffers hold one batch each
    /\ Len(txPrev) <= MaxBatch /\ Len(txCur) <= MaxBatch /\ Len(hostRx) <= MaxBatch
    /\ done \subseteq Ids /\ cbLog \in Seq([req: Ids, resp: Ids \cup {0}])
    /\ age \in [Ids -> 0..AgeCap] /\ deferred \in [Ids -> 0..MaxReq]
    /\ wrote \in BOOLEAN /\ readDone \in BOOLEAN

Init ==
    /\ nextId = 0 /\ budget = 0
    /\ hostQ = <<>> /\ expect = <<>> /\ rx = <<>>
    /\ txPrev = <<>> /\ txCur = <<>> /\ hostRx = <<>>
    /\ done = {} /\ cbLog = <<>>
    /\ age = [i \in Ids |-> 0] /\ deferred = [i \in Ids |-> 0]
    /\ wrote = FALSE /\ readDone = FALSE

Min(x, y) == IF x < y THEN x ELSE y
Take(s, n) == SubSeq(s, 1, Min(n, Len(s)))
Drop(s, n) == SubSeq(s, Min(n, Len(s)) + 1, Len(s))
Range(s) == {s[k] : k \in DOMAIN s}

(***************************************************************************)
(* Application: submitRequest() appends to USBManager's buffer.            *)
(***************************************************************************)
Submit ==
    /\ nextId < MaxReq /\ budget < MaxSubmit
    /\ nextId' = nextId + 1 /\ budget' = budget + 1
    /\ hostQ' = Append(hostQ, nextId + 1)
    /\ UNCHANGED <<expect, rx, txPrev, txCur, hostRx, done, cbLog, age,
                   deferred, wrote, readDone>>

(***************************************************************************)
(* Write thread (once per frame, on the tick): one bulk-OUT transfer with  *)
(* the first buffered requests, at most MaxBatch of them and no more than  *)
(* the window leaves room for (UsbCore.frame_out stops at                  *)
(* len(inflight) == window; a request leaves `inflight` when its response *)
(* is matched, which this model's Callback stands for).  The others stay   *)
(* buffered.                                                               *)
(***************************************************************************)
Room == Min(MaxBatch, Window - Len(expect))

UsbWrite ==
    /\ ~wrote
    /\ LET batch == Take(hostQ, Room)
           rest == Drop(hostQ, Room)
       IN /\ rx' = batch
          /\ hostQ' = rest
          /\ expect' = expect \o batch
          /\ deferred' = [i \in Ids |-> IF i \in Range(rest)
                                          THEN deferred[i] + 1 ELSE deferred[i]]
    /\ wrote' = TRUE /\ budget' = 0
    /\ UNCHANGED <<nextId, txPrev, txCur, hostRx, done, cbLog, age, readDone>>

(***************************************************************************)
(* Bridge: run the received batch over the downlink, in order; responses  *)
(* (echoing the sequence numbers) go to the CURRENT response buffer.       *)
(***************************************************************************)
BridgeProcess ==
    /\ rx # <<>>
    /\ txCur' = txCur \o [k \in DOMAIN rx |-> [id |-> rx[k], seq |-> rx[k] % SeqMod]]
    /\ rx' = <<>>
    /\ UNCHANGED <<nextId, budget, hostQ, expect, txPrev, hostRx, done, cbLog,
                   age, deferred, wrote, readDone>>

(***************************************************************************)
(* Read (once per frame): the bulk-IN transfer fetches the PREVIOUS        *)
(* response buffer (batch n-1), while batch n may be in progress.          *)
(***************************************************************************)
UsbRead ==
    /\ ~readDone
    /\ hostRx' = hostRx \o txPrev
    /\ txPrev' = <<>>
    /\ readDone' = TRUE
    /\ UNCHANGED <<nextId, budget, hostQ, expect, rx, txCur, done, cbLog, age,
                   deferred, wrote>>

(***************************************************************************)
(* Read thread: take the oldest unread response and match it as the host  *)
(* library does (ResponseMatcher.parse, shared with the RS232 core): to    *)
(* the oldest outstanding request whose sequence number (id mod SeqMod,   *)
(* UsbCore._next_seq) it echoes.  The outstanding requests before that    *)
(* one complete without a response (lost_before; logged with resp 0), and *)
(* a response that no outstanding request's number matches is discarded.  *)
(* Responses are never lost here (a USB transfer is checked end to end),  *)
(* so the match must always be the oldest; MCUsbUplinkWrap (SeqMod 4,     *)
(* 9 requests) explores the wrap.                                          *)
(***************************************************************************)
Callback ==
    /\ hostRx # <<>>
    /\ LET r == Head(hostRx)
           ks == {k \in DOMAIN expect : expect[k] % SeqMod = r.seq}
       IN IF ks = {} THEN UNCHANGED <<expect, done, cbLog>>
          ELSE LET k == CHOOSE k \in ks : \A j \in ks : k <= j
                   id == expect[k]
               IN /\ cbLog' = cbLog \o [j \in 1..k - 1 |-> [req |-> expect[j], resp |-> 0]]
                                  \o <<[req |-> id, resp |-> r.id]>>
                  /\ done' = done \cup {expect[j] : j \in 1..k}
                  /\ expect' = SubSeq(expect, k + 1, Len(expect))
    /\ hostRx' = Tail(hostRx)
    /\ UNCHANGED <<nextId, budget, hostQ, rx, txPrev, txCur, age, deferred,
                   wrote, readDone>>

(***************************************************************************)
(* Frame boundary: this frame's write, read, processing and callbacks are *)
(* over; the current response buffer becomes the previous one.            *)
(***************************************************************************)
Tick ==
    /\ wrote /\ readDone /\ rx = <<>> /\ hostRx = <<>>
    /\ wrote' = FALSE /\ readDone' = FALSE
    /\ txPrev' = txCur /\ txCur' = <<>>
    /\ age' = [i \in Ids |-> IF i <= nextId /\ i \notin done
                               THEN Min(age[i] + 1, AgeCap) ELSE age[i]]
    /\ UNCHANGED <<nextId, budget, hostQ, expect, rx, hostRx, done, cbLog,
                   deferred>>

Next == Submit \/ UsbWrite \/ BridgeProcess \/ UsbRead \/ Callback \/ Tick

Spec == Init /\ [][Next]_vars /\ WF_vars(Tick) /\ WF_vars(UsbWrite)
        /\ WF_vars(UsbRead) /\ WF_vars(BridgeProcess) /\ WF_vars(Callback)

-----------------------------------------------------------------------------
Submitted == 1..nextId
InFlight == Range(hostQ) \cup Range(rx) \cup {r.id : r \in Range(txPrev)}
            \cup {r.id : r \in Range(txCur)} \cup {r.id : r \in Range(hostRx)}

(* Nothing is lost: every submitted request is somewhere in the pipeline  *)
(* or has had its callback.                                                *)
\* lobster-trace: urb.HOST_004
NothingLost == \A id \in Submitted : id \in InFlight \/ id \in done

(* Requests leave the host in the order they were submitted: those sent   *)
(* and not yet called back, then those still buffered, have increasing ids *)
(* (the bridge serves a batch in order, so two writes to one inbox land in *)
(* the order the application submitted them).                              *)
\* lobster-trace: urb.HOST_005
SubmissionOrderKept ==
    LET q == expect \o hostQ IN \A k \in 1..Len(q) - 1 : q[k] < q[k + 1]

(* The host never has more than Window requests in flight: the bridge's  *)
(* data slots and response ring (Bridge.tla HostWindow) and the 4-bit     *)
(* sequence number rely on it.                                             *)
\* lobster-trace: urb.HOST_003
WindowRespected == Len(expect) <= Window

(* Every callback receives the response to its own request, however often *)
(* the sequence number has wrapped: never another request's, and never    *)
(* none (no response is lost here, so none may be declared lost).         *)
\* lobster-trace: urb.HOST_004
ResponsesMatched ==
    \A k \in DOMAIN cbLog : cbLog[k].req = cbLog[k].resp

(* Latency, counted in frames touched (c - s + 1), is at most MaxLatency  *)
(* plus one frame for every time the request was left behind (full batch *)
(* or full window).  Checked for requests still waiting too, so it fails  *)
(* as soon as a frame ends without the callback that was due.             *)
\* lobster-trace: urb.LAT_002
LatencyBound == \A id \in Submitted : age[id] + 1 <= MaxLatency + deferred[id]

(* Within the budget nothing is deferred: the paper's strict bound of     *)
(* MaxLatency frames.  The budget is MaxSubmit <= MaxBatch AND            *)
(* 2 * MaxSubmit <= Window: the write of frame n may come before the read *)
(* that completes batch n-1, so two frames' requests are in flight at     *)
(* once.  (TLC: MaxBatch = MaxSubmit = 2 with Window = 3 defers a request *)
(* and misses the bound in 4 frames; Window = 4 meets it.)                 *)
\* lobster-trace: urb.LAT_001
StrictLatency == \A id \in Submitted : age[id] + 1 <= MaxLatency

(* Liveness: every submitted request gets its callback:                    *)
(*     \A id \in Ids : (id <= nextId) ~> (id \in done)                       *)
(* stated as: again and again, every request submitted so far has had its *)
(* callback.  Equivalent: done never shrinks and at most MaxReq requests   *)
(* are submitted (see Bridge.tla's EveryRequestAnswered); TLC checks one   *)
(* tableau instead of one per request.                                      *)
\* lobster-trace: urb.HOST_001
EveryCallbackRuns == []<>(1..nextId \subseteq done)

-----------------------------------------------------------------------------
(* Reachability witnesses (spec/tla/manifest.json lists them per model).   *)
(* A full batch is written; the window is full; a request is left behind  *)
(* (full batch or full window); both response buffers hold responses (the *)
(* pipelining); a callback comes exactly at the latency bound, and one at  *)
(* the bound plus its deferrals; a request numbered after the sequence     *)
(* number wrapped gets its callback; every callback has run.              *)
ReachFullBatch == Len(rx) = MaxBatch
ReachWindowFull == Len(expect) = Window
ReachDeferral == \E id \in Ids : deferred[id] > 0
ReachBothBuffers == txPrev # <<>> /\ txCur # <<>>
ReachLatencyBound == \E id \in done : age[id] + 1 = MaxLatency
ReachDeferredLatencyBound ==
    \E id \in done : deferred[id] > 0 /\ age[id] + 1 = MaxLatency + deferred[id]
ReachSeqWrap == \E k \in DOMAIN cbLog : cbLog[k].req > SeqMod
ReachAllCalledBack == done = Ids

THEOREM Spec => [](TypeOK /\ NothingLost /\ ResponsesMatched /\ LatencyBound
                          /\ WindowRespected /\ SubmissionOrderKept)
THEOREM MaxSubmit <= MaxBatch /\ 2 * MaxSubmit <= Window => (Spec => []StrictLatency)
=============================================================================
