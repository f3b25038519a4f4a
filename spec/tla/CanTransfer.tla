---------------------------- MODULE CanTransfer ----------------------------
(***************************************************************************)
(* Segmentation and reassembly of URB transfers on CAN (spec/schema/       *)
(* README.md, "CAN downlink"; firmware/downlink/can/: urb_can_transfer.c,  *)
(* urb_can_slave.c, urb_can_master.c).                                     *)
(*                                                                         *)
(* Senders (the bridge, or nodes answering) each send their transfers on  *)
(* their own identifier (session), frame by frame in order: a transfer of *)
(* n frames carries the tail bits start (frame 1), end (frame n), toggle   *)
(* (1, 0, 1, ...) and its transfer id (transfer number - 1 mod TidMod).    *)
(* The bus takes a frame from the head of any sender's queue: arbitration *)
(* by identifier interleaves the frames of different transfers, never     *)
(* reorders one sender's.  Faults: a receiver loses a frame (overrun), a  *)
(* frame is taken twice (the sender saw an error in the last bit of the   *)
(* end of frame and sends it again), an error frame (nobody takes it, the *)
(* sender's error counter grows; at BusOffAt errors it is bus-off, drops  *)
(* its queue, and recovers later).                                         *)
(*                                                                         *)
(* The receiver keeps one reassembly per session and the transfer id of   *)
(* the request it completed last (the duplicate filter).  A frame is one  *)
(* record; the transfer CRC is modelled as ideal: it holds exactly when   *)
(* the frames reassembled are frames 1..n of one transfer, in order (a    *)
(* CRC-16 misses a changed transfer with probability 2^-16, not modelled).*)
(***************************************************************************)
EXTENDS Naturals, Sequences, FiniteSets

CONSTANTS
    Senders,    \* the sessions (one identifier each)
    Lens,       \* Lens[s]: sequence of the frame counts of s's transfers
    TidMod,     \* transfer ids count modulo TidMod (32 on the wire)
    MaxLoss,    \* frames lost at the receiver, at most
    MaxDup,     \* frames taken twice, at most
    MaxErr,     \* error frames, at most
    BusOffAt    \* error frames in a row that make a sender bus-off (32 on the wire)

ASSUME /\ TidMod \in Nat \ {0, 1} /\ MaxLoss \in Nat /\ MaxDup \in Nat
       /\ MaxErr \in Nat /\ BusOffAt \in Nat \ {0}
       \* a transfer id is reused on a session only after TidMod - 1 others,
       \* each of whose start frames would have to be lost for two transfers
       \* with one id to meet in one reassembly
       /\ MaxLoss < TidMod

NONE == TidMod   \* "no transfer id"

Xfers(s) == 1..Len(Lens[s])
Tid(x) == (x - 1) % TidMod

(* Frame i of transfer x of sender s. *)
Frame(s, x, i) ==
    [s |-> s, x |-> x, i |-> i, n |-> Lens[s][x], tid |-> Tid(x),
     tog |-> (i % 2 = 1), start |-> (i = 1), end |-> (i = Lens[s][x])]

Frames(s, x) == [i \in 1..Lens[s][x] |-> Frame(s, x, i)]

Events == {"none", "accept", "deliver", "toggle", "tid", "nostart", "dup", "crc"}

VARIABLES
    sent,      \* sent[s]: transfers s has queued so far
    q,         \* q[s]: s's frames not yet sent, in order (its transmit queue)
    tec,       \* tec[s]: error frames since s's last good frame (abstract TEC)
    busOff,    \* busOff[s]
    rx,        \* rx[s]: reassembly of session s: [active, tid, tog, buf]
    last,      \* last[s]: transfer id completed last on session s, or NONE
    count,     \* count[s][x]: times transfer x of s was delivered (capped at 2)
    done,      \* ghost: done[s], the frames of the reassembly s completed last (delivered or not)
    bad,       \* ghost: a delivered transfer was not frames 1..n of one transfer
    faults,    \* [loss, dup, err] used so far
    ev,        \* ghost: what the last receive did
    recovered  \* ghost: a bus-off sender recovered

vars == <<sent, q, tec, busOff, rx, last, count, done, bad, faults, ev, recovered>>

FrameT == [s : Senders, x : Nat, i : Nat, n : Nat, tid : Nat, tog : BOOLEAN,
           start : BOOLEAN, end : BOOLEAN]

TypeOK ==
    /\ sent \in [Senders -> Nat] /\ \A s \in Senders : sent[s] <= Len(Lens[s])
    /\ q \in [Senders -> Seq(FrameT)]
    /\ tec \in [Senders -> 0..BusOffAt] /\ busOff \in [Senders -> BOOLEAN]
    /\ \A s \in Senders : rx[s].active \in BOOLEAN /\ rx[s].tid \in 0..TidMod
                          /\ rx[s].tog \in BOOLEAN /\ rx[s].buf \in Seq(FrameT)
    /\ last \in [Senders -> 0..TidMod]
    /\ \A s \in Senders : count[s] \in [Xfers(s) -> 0..2]
    /\ done \in [Senders -> Seq(FrameT)]
    /\ bad \in BOOLEAN /\ faults \in [loss : Nat, dup : Nat, err : Nat]
    /\ ev \in Events /\ recovered \in BOOLEAN

Init ==
    /\ sent = [s \in Senders |-> 0]
    /\ q = [s \in Senders |-> <<>>]
    /\ tec = [s \in Senders |-> 0]
    /\ busOff = [s \in Senders |-> FALSE]
    /\ rx = [s \in Senders |-> [active |-> FALSE, tid |-> NONE, tog |-> TRUE, buf |-> <<>>]]
    /\ last = [s \in Senders |-> NONE]
    /\ count = [s \in Senders |-> [x \in Xfers(s) |-> 0]]
    /\ done = [s \in Senders |-> <<>>]
    /\ bad = FALSE
    /\ faults = [loss |-> 0, dup |-> 0, err |-> 0]
    /\ ev = "none"
    /\ recovered = FALSE

(***************************************************************************)
(* urb_can_tx_init: the next transfer's frames join the sender's queue     *)
(* (a sender queues a transfer once the previous one is out).              *)
(***************************************************************************)
SendStart(s) ==
    /\ ~busOff[s] /\ q[s] = <<>> /\ sent[s] < Len(Lens[s])
    /\ sent' = [sent EXCEPT ![s] = @ + 1]
    /\ q' = [q EXCEPT ![s] = Frames(s, sent[s] + 1)]
    /\ UNCHANGED <<tec, busOff, rx, last, count, done, bad, faults, ev, recovered>>

(* The transfer the receiver completed: delivered if its CRC holds.        *)
Complete(s, buf, single, checkCrc) ==
    LET x == buf[1].x
        intact == Len(buf) = buf[1].n /\ buf = Frames(s, x)
    IN  /\ done' = [done EXCEPT ![s] = buf]
        /\ IF single \/ intact \/ ~checkCrc
           THEN /\ count' = [count EXCEPT ![s][x] = IF @ < 2 THEN @ + 1 ELSE 2]
                /\ bad' = (bad \/ ~(Len(buf) = buf[1].n /\ buf = Frames(s, x)))
                /\ ev' = "deliver"
           ELSE /\ ev' = "crc" /\ UNCHANGED <<count, bad>>

(***************************************************************************)
(* urb_can_rx_frame with the node's duplicate filter (urb_can_slave_rx):   *)
(* a start frame that is not a repeat of the transfer in progress begins a *)
(* transfer, unless it repeats the one completed last (DuplicateIgnored);  *)
(* any other frame must continue the transfer in progress with its id and *)
(* the expected toggle bit.                                                *)
(***************************************************************************)
ReceiveWith(s, f, checkTog, checkTid, checkDup, checkCrc) ==
    LET r == rx[s] IN
    IF f.start /\ ~(r.active /\ f.tid = r.tid)
    THEN IF checkDup /\ f.tid = last[s]
         THEN /\ ev' = "dup"   \* DuplicateIgnored
              /\ UNCHANGED <<rx, last, count, done, bad>>
         ELSE IF f.end
              THEN /\ rx' = [rx EXCEPT ![s] = [active |-> FALSE, tid |-> f.tid, tog |-> TRUE, buf |-> <<>>]]
                   /\ last' = [last EXCEPT ![s] = f.tid]
                   /\ Complete(s, <<f>>, TRUE, checkCrc)
              ELSE /\ rx' = [rx EXCEPT ![s] = [active |-> TRUE, tid |-> f.tid, tog |-> FALSE, buf |-> <<f>>]]
                   /\ ev' = "accept"
                   /\ UNCHANGED <<last, count, done, bad>>
    ELSE IF ~r.active
         THEN /\ ev' = "nostart" /\ UNCHANGED <<rx, last, count, done, bad>>
    ELSE IF checkTid /\ f.tid # r.tid
         THEN /\ ev' = "tid" /\ UNCHANGED <<rx, last, count, done, bad>>
    ELSE IF checkTog /\ f.tog # r.tog
         THEN /\ ev' = "toggle" /\ UNCHANGED <<rx, last, count, done, bad>>
    ELSE IF f.end
         THEN /\ rx' = [rx EXCEPT ![s] = [active |-> FALSE, tid |-> r.tid, tog |-> TRUE, buf |-> <<>>]]
              /\ last' = [last EXCEPT ![s] = r.tid]
              /\ Complete(s, Append(r.buf, f), FALSE, checkCrc)
         ELSE /\ rx' = [rx EXCEPT ![s].buf = Append(@, f), ![s].tog = ~@]
              /\ ev' = "accept"
              /\ UNCHANGED <<last, count, done, bad>>

(* The receiver as the firmware has it: every check on. Mutants switch one *)
(* off (spec/tla/mutants/CanTransfer_*.tla).                               *)
Receive(s, f) == ReceiveWith(s, f, TRUE, TRUE, TRUE, TRUE)

(***************************************************************************)
(* The bus sends the head of s's queue (it won arbitration) and everybody  *)
(* takes it: the sender's error count falls back.                          *)
(***************************************************************************)
SendFrameBy(s, R(_, _)) ==
    /\ ~busOff[s] /\ q[s] # <<>>
    /\ q' = [q EXCEPT ![s] = Tail(@)]
    /\ tec' = [tec EXCEPT ![s] = 0]
    /\ R(s, Head(q[s]))
    /\ UNCHANGED <<sent, busOff, faults, recovered>>

(* The receiver loses the frame (its controller's receive buffer overran); *)
(* the sender saw it acknowledged by others.                               *)
Lose(s) ==
    /\ ~busOff[s] /\ q[s] # <<>> /\ faults.loss < MaxLoss
    /\ q' = [q EXCEPT ![s] = Tail(@)]
    /\ faults' = [faults EXCEPT !.loss = @ + 1]
    /\ UNCHANGED <<sent, tec, busOff, rx, last, count, done, bad, ev, recovered>>

(* The receiver takes the frame, the sender sees an error in the last bit  *)
(* of the end of frame and sends it again: the frame stays at the head.    *)
DuplicateBy(s, R(_, _)) ==
    /\ ~busOff[s] /\ q[s] # <<>> /\ faults.dup < MaxDup
    /\ faults' = [faults EXCEPT !.dup = @ + 1]
    /\ R(s, Head(q[s]))
    /\ UNCHANGED <<sent, q, tec, busOff, recovered>>

(* An error frame: nobody takes the frame; at BusOffAt errors in a row the *)
(* sender is bus-off and its queue is dropped (the master's tx_abort).     *)
ErrorFrame(s) ==
    /\ ~busOff[s] /\ q[s] # <<>> /\ faults.err < MaxErr
    /\ faults' = [faults EXCEPT !.err = @ + 1]
    /\ tec' = [tec EXCEPT ![s] = @ + 1]
    /\ IF tec[s] + 1 >= BusOffAt
       THEN /\ busOff' = [busOff EXCEPT ![s] = TRUE] /\ q' = [q EXCEPT ![s] = <<>>]
       ELSE UNCHANGED <<busOff, q>>
    /\ UNCHANGED <<sent, rx, last, count, done, bad, ev, recovered>>

(* Recovery: 128 x 11 recessive bits later the sender is error-active.     *)
Recover(s) ==
    /\ busOff[s]
    /\ busOff' = [busOff EXCEPT ![s] = FALSE] /\ tec' = [tec EXCEPT ![s] = 0]
    /\ recovered' = TRUE
    /\ UNCHANGED <<sent, q, rx, last, count, done, bad, faults, ev>>

SendFrame(s) == SendFrameBy(s, Receive)
Duplicate(s) == DuplicateBy(s, Receive)

(* Every transfer sent and every sender on the bus: the model ends.        *)
Terminated == /\ \A s \in Senders : q[s] = <<>> /\ ~busOff[s] /\ sent[s] = Len(Lens[s])
              /\ UNCHANGED vars

NextBy(R(_, _)) == \/ \E s \in Senders : SendStart(s) \/ SendFrameBy(s, R) \/ Lose(s) \/ DuplicateBy(s, R)
                                        \/ ErrorFrame(s) \/ Recover(s)
                   \/ Terminated
\* NextBy(Receive) spelled out, so that the firmware can cite its actions by name (tools/tla_xref.py).
Next == \/ \E s \in Senders : SendStart(s) \/ SendFrame(s) \/ Lose(s) \/ Duplicate(s)
                              \/ ErrorFrame(s) \/ Recover(s)
        \/ Terminated

Spec == Init /\ [][Next]_vars

-----------------------------------------------------------------------------
(* A reassembly, in progress or the one completed last, never holds frames *)
(* of two transfers.                                                       *)
OneTransfer(buf) == \A i, j \in DOMAIN buf : buf[i].x = buf[j].x
\* lobster-trace: urb.DLK_001
NoMixedTransfers == \A s \in Senders : OneTransfer(rx[s].buf) /\ OneTransfer(done[s])

(* ...nor one frame twice (the toggle bit's job).                          *)
NoRepeat(buf) == \A i, j \in DOMAIN buf : i # j => buf[i] # buf[j]
\* lobster-trace: urb.DLK_001
NoRepeatedFrame == \A s \in Senders : NoRepeat(rx[s].buf) /\ NoRepeat(done[s])

(* A delivered transfer is exactly one sent transfer, every frame in order *)
(* (the CRC's job for a multi-frame transfer).                             *)
\* lobster-trace: urb.DLK_002
DeliveredIntact == ~bad

(* No transfer is delivered twice (the duplicate filter's job).            *)
\* lobster-trace: urb.DLK_003
AtMostOnce == \A s \in Senders : \A x \in Xfers(s) : count[s][x] <= 1

(* Without a lost or repeated frame every transfer is delivered, except  *)
(* those a bus-off cut (it drops the sender's queue: at most one transfer *)
(* per bus-off, and a bus-off takes BusOffAt error frames): the receiver's *)
(* checks refuse nothing the bus carried whole, and a transfer cut short  *)
(* does not block the next (the checks above hold for a receiver that     *)
(* refuses everything).                                                    *)
NoLossNoRepeat == faults.loss = 0 /\ faults.dup = 0
AllSent == \A s \in Senders : sent[s] = Len(Lens[s]) /\ q[s] = <<>>
Undelivered == UNION {{<<s, x>> : x \in {y \in Xfers(s) : count[s][y] = 0}} : s \in Senders}
\* lobster-trace: urb.DLK_001
DeliveredUnlessCut == NoLossNoRepeat /\ AllSent => Cardinality(Undelivered) <= faults.err \div BusOffAt

THEOREM Spec => [](TypeOK /\ NoMixedTransfers /\ NoRepeatedFrame /\ DeliveredIntact /\ AtMostOnce
                   /\ DeliveredUnlessCut)

-----------------------------------------------------------------------------
(* Reachability witnesses (manifest.json "witnesses", tools/tla_witness.py):*)
(* the situations the invariants are about, each of which a model must     *)
(* reach in its own run.                                                   *)
ReachMultiFrameDone == \E s \in Senders : \E x \in Xfers(s) : Lens[s][x] > 1 /\ count[s][x] > 0
ReachToggleRejected == ev = "toggle"       \* a repeated frame refused by its toggle bit
ReachDuplicateDropped == ev = "dup"        \* a repeated single-frame transfer ignored
ReachCrcRejected == ev = "crc"             \* a transfer missing a frame refused by the CRC
ReachInterleaved == \E s, t \in Senders : s # t /\ rx[s].active /\ rx[t].active
ReachBusOffRecovered == recovered          \* a sender bus-off and back on the bus
ReachCleanRunDone == NoLossNoRepeat /\ faults.err = 0 /\ AllSent   \* all sent without a fault
\* a bus-off cut a transfer, its sender recovered, and every transfer sent: one is
\* undelivered, the rest are
ReachCutRunDone == NoLossNoRepeat /\ AllSent /\ (\A s \in Senders : ~busOff[s])
                   /\ Cardinality(Undelivered) = 1
=============================================================================
