----------------------------- MODULE Rs485Poll -----------------------------
(***************************************************************************)
(* The RS485 poll cycle (spec/schema/README.md, "RS485 downlink";           *)
(* firmware/downlink/rs485/: urb_rs485_master.c, urb_rs485_slave.c), at    *)
(* the level of whole frames on a half-duplex line.                        *)
(*                                                                         *)
(* The bridge polls one address at a time with a write (a request that     *)
(* changes the node when it takes it).  It sends only on a silent line; it *)
(* hears its own frame, and an echo that differs (a babbler drives too) is *)
(* a collision.  Cut before the last byte, the frame reaches nobody,       *)
(* unless the bytes the line carried up to the cut form a shorter          *)
(* well-formed frame whose check passes (a frame's length is its byte      *)
(* count; CRC-8: about one cut in 256): then the polled node takes it as a *)
(* shorter write, and the bridge, which computes the same check over what  *)
(* it sent and the byte it heard, reports TIMEOUT.  On the last byte the   *)
(* node may or may not take the frame.  The polled node, if present and    *)
(* if its frame arrived whole, takes it at the frame's end (t3.5 of        *)
(* silence) and answers at once; a babbler that talks before that breaks   *)
(* the frame (Modbus: discarded): no node takes it, and the bridge, which  *)
(* hears the break, drains and reports BUS_STUCK (issue #39: it used to    *)
(* wait on, take the babbler's frame end for its request's and report the  *)
(* node's silence NO_NODE).  No answer: the bridge's silence timeout      *)
(* (t3.5 + turnaround + a character) gives NO_NODE.  A babbler may talk at *)
(* any time; bytes the bridge hears while nobody was polled are counted.   *)
(* Outcomes (status names of core.urbs): OK, CHECKSUM (the node's check    *)
(* failed: not stored), TIMEOUT (a corrupted answer, or a cut whose bytes  *)
(* pass a check: unknown), NO_NODE, BUS_STUCK (cut or broken: not         *)
(* executed).                                                              *)
(***************************************************************************)
EXTENDS Naturals, Sequences, FiniteSets

CONSTANTS
    Nodes,      \* addresses of the nodes on the line
    Polls,      \* the addresses the bridge polls, in order (some may be absent)
    MaxBabble   \* bursts of the babbler

ASSUME MaxBabble \in Nat

BRIDGE == "bridge"
BABBLER == "babbler"
NOBODY == "nobody"
Talkers == Nodes \cup {BRIDGE, BABBLER}
Results == {"none", "OK", "CHECKSUM", "TIMEOUT", "NO_NODE", "BUS_STUCK"}
\* what the polled node stored: nothing, the request, or the shorter write of a cut frame
Stores == {"nothing", "request", "shorter"}

VARIABLES
    k,          \* the poll in progress (index into Polls), Len(Polls) + 1 when all done
    phase,      \* bridge: "idle", "send", "wait", "answer", "drain", "done"
    drivers,    \* who drives the line now
    cut,        \* the collision cut the request before its last byte and the bytes the
                \* line carried are no frame a check accepts (the master's `cut`)
    due,        \* the node that will answer (it took the request or must refuse it), or NOBODY
    got,        \* what the polled node received: "none", "intact", "corrupt", or "short"
                \* (the frame cut by a collision, whose bytes pass its check); "broken": the
                \* request's frame, out whole, broke before its t3.5 (no node received it)
    stored,     \* ghost: what the polled node stored (Stores)
    storesOf,   \* ghost: storesOf[i], how many times the node polled i-th stored a frame of that poll
    garbled,    \* the answer heard was overlapped by the babbler
    from,       \* who sent the answer the bridge hears
    result,     \* the bridge's outcome of the poll in progress
    babbleLeft, \* babbler bursts left
    babbledIdle,\* ghost: the babbler talked while nobody was polled
    heard,      \* the bridge's babble counter (capped at 1)
    reported    \* ghost: outcomes reported, as [result, stored] records

vars == <<k, phase, drivers, cut, due, got, stored, storesOf, garbled, from, result, babbleLeft,
          babbledIdle, heard, reported>>

Target == Polls[k]

TypeOK ==
    /\ k \in 1..Len(Polls) + 1
    /\ phase \in {"idle", "send", "wait", "answer", "drain", "done"}
    /\ drivers \subseteq Talkers /\ cut \in BOOLEAN
    /\ due \in Nodes \cup {NOBODY} /\ got \in {"none", "intact", "corrupt", "short", "broken"}
    /\ stored \in Stores /\ storesOf \in [1..Len(Polls) -> Nat] /\ garbled \in BOOLEAN /\ from \in Talkers \cup {NOBODY}
    /\ result \in Results /\ babbleLeft \in 0..MaxBabble
    /\ babbledIdle \in BOOLEAN /\ heard \in 0..1
    /\ reported \in Seq([result : Results, stored : Stores])

Init ==
    /\ k = 1 /\ phase = "idle" /\ drivers = {} /\ cut = FALSE /\ due = NOBODY
    /\ got = "none" /\ stored = "nothing" /\ garbled = FALSE /\ from = NOBODY
    /\ storesOf = [i \in 1..Len(Polls) |-> 0]
    /\ result = "none" /\ babbleLeft = MaxBabble /\ babbledIdle = FALSE /\ heard = 0
    /\ reported = <<>>

(***************************************************************************)
(* master_begin / send: the bridge polls the next address on a silent line.*)
(***************************************************************************)
Poll ==
    /\ phase = "idle" /\ k <= Len(Polls) /\ drivers = {}
    /\ phase' = "send" /\ drivers' = {BRIDGE}
    /\ cut' = FALSE /\ got' = "none" /\ stored' = "nothing" /\ garbled' = FALSE
    /\ from' = NOBODY /\ result' = "none" /\ due' = NOBODY
    /\ UNCHANGED <<k, storesOf, babbleLeft, babbledIdle, heard, reported>>

(* urb_rs485_master_rx, Collide: an echo byte before the last differs. The *)
(* bridge stops driving and waits for silence.  The bytes the line carried *)
(* up to the cut may pass a check (`passes`: the model has no byte counts, *)
(* so any cut may; the firmware's cut_frame_passes_check needs 3 bytes):   *)
(* then the polled node, if present, takes them at its t3.5 as a shorter   *)
(* write, and a bridge that checks the cut (checkCut, the firmware since   *)
(* 2026-11-29) does not call it cut: TIMEOUT, not BUS_STUCK.               *)
CollideMidWith(checkCut) ==
    /\ phase = "send" /\ BABBLER \in drivers
    /\ phase' = "drain" /\ drivers' = drivers \ {BRIDGE}
    /\ \E passes \in BOOLEAN :
          /\ cut' = ~(checkCut /\ passes)
          /\ got' = IF passes /\ Target \in Nodes THEN "short" ELSE "none"
          /\ due' = IF passes /\ Target \in Nodes THEN Target ELSE NOBODY
    /\ UNCHANGED <<k, stored, storesOf, garbled, from, result, babbleLeft, babbledIdle, heard, reported>>

CollideMid == CollideMidWith(TRUE)

(* The request's last byte is out: the polled node (if any) has the frame, *)
(* whole or (a babbler on the last byte) possibly corrupted.              *)
SendEndWith(stuck) ==
    /\ phase = "send"
    /\ \E g \in (IF BABBLER \in drivers THEN {"intact", "corrupt"} ELSE {"intact"}) :
          /\ got' = IF Target \in Nodes THEN g ELSE "none"
          /\ due' = IF Target \in Nodes THEN Target ELSE NOBODY
    \* a bridge that calls a collision on the last byte a cut (stuck: the
    \* mutant Rs485Poll_CollisionAlwaysStuck) drains and reports BUS_STUCK
    /\ phase' = IF stuck /\ BABBLER \in drivers THEN "drain" ELSE "wait"
    /\ cut' = (stuck /\ BABBLER \in drivers)
    /\ drivers' = drivers \ {BRIDGE}
    /\ UNCHANGED <<k, stored, storesOf, garbled, from, result, babbleLeft, babbledIdle, heard, reported>>

SendEnd == SendEndWith(FALSE)

(* urb_rs485_slave: at t3.5 of silence the node takes the frame (stored if *)
(* whole or a cut frame that passes its check, CHECKSUM if corrupt) and   *)
(* drives its answer.                                                      *)
Answer(n) ==
    /\ due = n /\ drivers = {}
    /\ stored' = CASE got = "intact" -> "request"
                    [] got = "short" -> "shorter"
                    [] OTHER -> "nothing"
    /\ storesOf' = IF got \in {"intact", "short"} THEN [storesOf EXCEPT ![k] = @ + 1] ELSE storesOf
    /\ drivers' = {n} /\ due' = NOBODY /\ from' = n
    /\ phase' = IF phase = "wait" THEN "answer" ELSE phase
    /\ UNCHANGED <<k, cut, got, garbled, result, babbleLeft, babbledIdle, heard, reported>>

(* The answer's last byte: the bridge judges it (at its t3.5, folded in).  *)
AnswerEnd(n) ==
    /\ n \in drivers /\ n \in Nodes
    /\ drivers' = drivers \ {n}
    /\ IF phase = "answer"
       THEN /\ result' = IF garbled \/ BABBLER \in drivers THEN "TIMEOUT"
                         ELSE IF got = "intact" THEN "OK" ELSE "CHECKSUM"
            /\ phase' = "done"
       ELSE UNCHANGED <<result, phase>>
    /\ UNCHANGED <<k, cut, due, got, stored, storesOf, garbled, from, babbleLeft, babbledIdle, heard, reported>>

(* Silence: no answer began within t3.5 + the turnaround: NO_NODE.        *)
SilenceWith(early) ==
    /\ phase = "wait" /\ drivers = {} /\ (early \/ due = NOBODY)
    /\ result' = "NO_NODE" /\ phase' = "done"
    /\ UNCHANGED <<k, drivers, cut, due, got, stored, storesOf, garbled, from, babbleLeft, babbledIdle, heard, reported>>

Silence == SilenceWith(FALSE)

(* After a collision the bridge waits for silence: BUS_STUCK (not         *)
(* executed) for a cut frame, TIMEOUT for one whose bytes pass a check.   *)
(* The node's t3.5 and the bridge's end of frame coincide; the node's     *)
(* decision is folded in first (due = NOBODY: taken, or broken by babble), *)
(* so the ghost `stored` is final when the outcome is reported.           *)
Drain ==
    /\ phase = "drain" /\ drivers = {} /\ due = NOBODY
    /\ result' = IF cut THEN "BUS_STUCK" ELSE "TIMEOUT"
    /\ phase' = "done"
    /\ UNCHANGED <<k, drivers, cut, due, got, stored, storesOf, garbled, from, babbleLeft, babbledIdle, heard, reported>>

(* poll() returns the outcome; the next poll may follow.                   *)
Report ==
    /\ phase = "done"
    /\ reported' = Append(reported, [result |-> result, stored |-> stored])
    /\ k' = k + 1 /\ phase' = "idle"
    /\ UNCHANGED <<drivers, cut, due, got, stored, storesOf, garbled, from, result, babbleLeft, babbledIdle, heard>>

(***************************************************************************)
(* The babbler starts talking: while nobody is polled the bridge counts it;*)
(* during the request it collides; before a node's t3.5 it breaks the     *)
(* frame the node waits on (the request's, or a cut one that passes a     *)
(* check); during an answer it garbles it; in the bridge's wait it is     *)
(* heard as an answer that will not check.                                 *)
(* "wait" on a silent line folds two firmware phases: SENT (the request's *)
(* last byte out, its t3.5 to come) and WAIT (the node's turn).  A talker  *)
(* in SENT (`breaks`) breaks the request's frame: no node takes it (got =  *)
(* "broken"); the bridge hears the break (the receiver's EV_BROKEN) and,   *)
(* if it reacts (the firmware since issue #39's fix), drains: BUS_STUCK at *)
(* silence.  One that does not (Rs485Poll_SentIgnoresBreak, the firmware   *)
(* before) stays in "wait": the babbler's frame end, when it stops, is     *)
(* taken for the request's, and the silence after it is NO_NODE.  A       *)
(* talker in WAIT is heard as an answer; only when no node is due (a due   *)
(* node's answer starts at the t3.5, folded into Answer).                  *)
(***************************************************************************)
BabbleStartWith(counted, reacts) ==   \* counted: the phases in which the bridge counts babble
    /\ babbleLeft > 0 /\ BABBLER \notin drivers
    /\ drivers' = drivers \cup {BABBLER} /\ babbleLeft' = babbleLeft - 1
    /\ babbledIdle' = (babbledIdle \/ phase \in {"idle", "done"})
    /\ heard' = IF phase \in counted THEN 1 ELSE heard
    /\ due' = IF drivers = {} /\ phase \in {"wait", "drain"} THEN NOBODY ELSE due
    /\ \E breaks \in IF phase = "wait" /\ drivers = {}
                     THEN (IF due = NOBODY THEN BOOLEAN ELSE {TRUE}) ELSE {FALSE} :
          /\ got' = IF breaks THEN "broken" ELSE got
          /\ garbled' = (garbled \/ phase = "answer" \/ (phase = "wait" /\ drivers = {} /\ ~breaks))
          /\ IF breaks
             THEN /\ from' = from
                  /\ phase' = IF reacts THEN "drain" ELSE phase
                  /\ cut' = (reacts \/ cut)
             ELSE /\ cut' = cut
                  /\ IF phase = "wait" /\ drivers = {}
                     THEN phase' = "answer" /\ from' = BABBLER
                     ELSE UNCHANGED <<phase, from>>
    /\ UNCHANGED <<k, stored, storesOf, result, reported>>

BabbleStart == BabbleStartWith({"idle", "done"}, TRUE)

BabbleStop ==
    /\ BABBLER \in drivers
    /\ drivers' = drivers \ {BABBLER}
    /\ IF phase = "answer" /\ from = BABBLER
       THEN result' = "TIMEOUT" /\ phase' = "done"
       ELSE UNCHANGED <<result, phase>>
    /\ UNCHANGED <<k, cut, due, got, stored, storesOf, garbled, from, babbleLeft, babbledIdle, heard, reported>>

Terminated == k > Len(Polls) /\ drivers = {} /\ UNCHANGED vars

NextWith(collide, send, silence, babble) ==
        \/ Poll \/ collide \/ send \/ silence \/ Drain \/ Report
        \/ \E n \in Nodes : Answer(n) \/ AnswerEnd(n)
        \/ babble \/ BabbleStop \/ Terminated

Next == NextWith(CollideMid, SendEnd, Silence, BabbleStart)

Spec == Init /\ [][Next]_vars

-----------------------------------------------------------------------------
(* One talker at a time among the bridge and the nodes (the babbler is the *)
(* fault the others detect).                                               *)
\* lobster-trace: urb.DLK_004
OneTalker == Cardinality(drivers \ {BABBLER}) <= 1

(* ...and the node that talks is the one polled (its address filter): no  *)
(* node answers a poll of another address, present or absent.             *)
\* lobster-trace: urb.DLK_004
OnlyPolledNodeTalks == \A n \in Nodes : n \in drivers => k <= Len(Polls) /\ n = Target

(* A reported outcome tells the truth about the node's mailbox: OK only if *)
(* it stored the request; CHECKSUM, NO_NODE and BUS_STUCK only if it       *)
(* stored nothing, neither the request nor the shorter write of a cut     *)
(* frame (TIMEOUT says nothing); and every poll reports an outcome.        *)
(* Bridge.tla's WriteStatusTruthful.                                       *)
\* lobster-trace: urb.DLK_004
StatusTruthful == \A i \in DOMAIN reported :
    /\ reported[i].result # "none"
    /\ reported[i].result = "OK" => reported[i].stored = "request"
    /\ reported[i].result \in {"CHECKSUM", "NO_NODE", "BUS_STUCK"} => reported[i].stored = "nothing"

(* A poll's request is stored at most once: the bridge never sends it    *)
(* again, not even when its outcome is unknown (URB has no retransmission:*)
(* the node may have stored the first).                                    *)
\* lobster-trace: urb.DLK_004
StoredAtMostOnce == \A i \in DOMAIN storesOf : storesOf[i] <= 1

(* NO_NODE only for a request whose frame went out whole and unbroken: the *)
(* node's silence says nothing about a request no node received (issue    *)
(* #39: a frame broken after its last byte, or cut, is no poll).  Checked  *)
(* where the outcome is ready (phase "done": got is that poll's until the  *)
(* next Poll, after Report).                                               *)
\* lobster-trace: urb.DLK_004
NoNodeOnlyWhole == (phase = "done" /\ result = "NO_NODE") => got \notin {"broken", "short"}

(* Bytes heard while nobody was polled are counted (babbling detected).    *)
\* lobster-trace: urb.DLK_005
BabbleCounted == babbledIdle => heard > 0

(* ...and only those: a collision or a garbled answer during a poll is    *)
(* not counted as babbling (the count blames a babbler).                  *)
\* lobster-trace: urb.DLK_005
NoFalseBabble == heard > 0 => babbledIdle

THEOREM Spec => [](TypeOK /\ OneTalker /\ OnlyPolledNodeTalks /\ StatusTruthful /\ StoredAtMostOnce
                   /\ NoNodeOnlyWhole /\ BabbleCounted /\ NoFalseBabble)

-----------------------------------------------------------------------------
(* Reachability witnesses (manifest.json "witnesses", tools/tla_witness.py):*)
(* the situations the invariants are about, each of which a model must     *)
(* reach in its own run.                                                   *)
Reported(r, s) == \E i \in DOMAIN reported : reported[i].result = r /\ reported[i].stored \in s
\* a collision cut a request (its outcome ready: a break after the request's last byte, also
\* BUS_STUCK, is ReachBrokenAfterSent)
ReachCollisionDetected == phase = "done" /\ result = "BUS_STUCK" /\ got # "broken"
ReachSilentNode == Reported("NO_NODE", Stores)           \* the absent node
ReachBabblerCounted == heard > 0                          \* bytes heard while nobody was polled
ReachAnswerOk == Reported("OK", Stores)
\* the node stored the write and the babbler garbled its answer: only TIMEOUT is true
ReachGarbledAnswer == Reported("TIMEOUT", {"request"})
ReachNodeChecksum == Reported("CHECKSUM", Stores)         \* a request corrupted on its last byte
\* a write cut by a collision whose bytes passed the node's check: stored as a shorter write,
\* reported TIMEOUT (issue #39; fuzz_rs485's regress-rs485-cut-frame-passes-check)
ReachCutFrameStored == Reported("TIMEOUT", {"shorter"})
\* the request went out whole and a babbler broke its frame before its t3.5: BUS_STUCK (issue #39;
\* fw_rs485_master's cover point broken-after-request-bus-stuck)
ReachBrokenAfterSent == phase = "done" /\ result = "BUS_STUCK" /\ got = "broken"
=============================================================================
