-------------------------------- MODULE Bridge --------------------------------
(***************************************************************************)
(* Request ordering in one URB bridge (paper Sec. V-A, V-B, V-D).           *)
(*                                                                         *)
(* The CPU submits read/write requests addressed to (node, mailbox).  The  *)
(* bridge keeps them in arrival order in a ring of response slots; each    *)
(* request is answered exactly once, in arrival order, with no             *)
(* retransmission.  Memory is split in two bounded pools:                 *)
(*   - QueueLen data slots (a 32-byte payload buffer each), held by a      *)
(*     request from admission until its response has left the bridge;     *)
(*   - HostWindow response slots (header only: seq, status), one per       *)
(*     outstanding request.  The host never has more than HostWindow       *)
(*     requests outstanding on a bridge, so this ring never overflows.     *)
(* A request whose header is bad (BAD_REQUEST), whose length differs from  *)
(* the mailbox size learnt at discovery (SIZE_MISMATCH), or that finds all *)
(* data slots taken (BUSY) is answered at admission: its response is       *)
(* decided at once but is placed in the response ring in arrival order,   *)
(* so it never overtakes an earlier request.  The downlink serves the      *)
(* pending requests in arrival order; a transaction ends OK or with the    *)
(* error that names its cause.                                             *)
(*                                                                         *)
(* The host side of the uplink is modelled as the host library does it    *)
(* (host/urb/managers/rs232_core.py, ResponseMatcher, shared by the USB    *)
(* core): the n-th request of a host process carries the sequence number  *)
(* n mod SeqMod; the requests in flight are a FIFO, and a response is      *)
(* matched to the OLDEST request in flight whose sequence number it        *)
(* echoes, the ones before it                                              *)
(* completing as lost (the bridge is a FIFO: a later response proves them *)
(* lost).  With UplinkLoss a response may be lost on the uplink (corrupt   *)
(* bytes the host hunts past; a request lost on its way to the bridge     *)
(* looks the same to the host: no response ever comes), and the host      *)
(* may time out a request at any time, the bridge holding it or not (a    *)
(* bridge slower than the host's timeout).  A timed-out request completes *)
(* UPLINK_TIMEOUT but stays in flight as a PLACEHOLDER: its sequence      *)
(* number stays reserved and it keeps its window slot until its own late  *)
(* response arrives (discarded), a response to a later request passes it, *)
(* or its lifetime expires (premise: only once the bridge no longer holds *)
(* it).  The host's window counts ITS requests in flight, placeholders    *)
(* included, as the code does.  Small SeqMod (4) with more than SeqMod    *)
(* requests makes TLC explore the wrap.                                    *)
(*                                                                         *)
(* Three disruptions, each a specification of its own (SpecReconnect,     *)
(* SpecReset, SpecRestart; Spec has none):                                 *)
(*   - the host loses or closes its uplink and opens it again             *)
(*     (HostLinkLost, HostReopen: close(), an I/O error or a silent        *)
(*     bridge, then reconnect()).  The bridge is not reset by it: it keeps *)
(*     its queue and goes on answering; what it sends while the uplink is *)
(*     closed is lost.  The host's matcher state persists: its live        *)
(*     requests become placeholders, which reconnect keeps, and its        *)
(*     numbering goes on.                                                  *)
(*   - the bridge resets (power loss, watchdog): it forgets every request *)
(*     it holds (BridgeReset).  The host is not told; it times the         *)
(*     forgotten requests out and their placeholders expire.               *)
(*   - a NEW host process opens the uplink after the previous one ended    *)
(*     (HostRestart after HostLinkLost: killed, crashed or closed without  *)
(*     draining; each `urb` CLI command is a new process).  It numbers its *)
(*     requests from 1 again and has an empty in-flight list, so a late    *)
(*     answer to an earlier process's request could echo the number of one *)
(*     of its own.  The handover (host/urb/managers/handover.py            *)
(*     PortHandover, rs232_core.py MatchingCore.hand_over) makes it wait   *)
(*     until the bridge holds no request of an earlier process.            *)
(***************************************************************************)
EXTENDS Naturals, Sequences, FiniteSets

CONSTANTS
    Present,     \* downlink addresses that acknowledge (nodes on the bus)
    Requests,    \* request headers the host may submit: [addr, box, op, len]
    Size,        \* Size[addr][box]: mailbox size learnt at discovery
    Faults,      \* downlink failure causes explored (subset of DownlinkFaults)
    QueueLen,    \* bridge data slots
    HostWindow,  \* host's bound on outstanding requests = response slots
    MaxReq,      \* number of requests submitted in a behaviour
    SeqMod,      \* sequence numbers 0..SeqMod - 1 (the uplink's 4 bits: 16)
    UplinkLoss   \* TRUE: responses may be lost on the uplink, the host times out
                 \*   requests (the bridge may still hold them)

Statuses == {"OK", "TIMEOUT", "CHECKSUM", "BUSY", "NO_NODE", "SIZE_MISMATCH",
             "BAD_REQUEST", "BUS_STUCK", "NODE_BUSY"}
DownlinkFaults == {"TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY", "NO_NODE"}
AdmissionErrors == {"BUSY", "SIZE_MISMATCH", "BAD_REQUEST"}
NoData == <<>>

ASSUME /\ Faults \subseteq DownlinkFaults
       /\ QueueLen \in Nat \ {0} /\ HostWindow \in Nat \ {0}
       /\ QueueLen <= HostWindow /\ HostWindow < SeqMod
       /\ MaxReq \in Nat /\ SeqMod \in Nat \ {0} /\ UplinkLoss \in BOOLEAN

(* Content of outbox `box` of node `addr`: it names the mailbox it came     *)
(* from, so a response carrying another mailbox's data is detected.        *)
Outbox(addr, box) == <<addr, box>>

(* Header validation done at admission (no downlink traffic).              *)
\* lobster-trace: urb.PKT_003
AdmissionStatus(r) ==
    IF r.box \notin 0..7 \/ r.len \notin 1..32 THEN "BAD_REQUEST"
    ELSE IF r.addr \in Present /\ r.len # Size[r.addr][r.box]
         THEN "SIZE_MISMATCH" ELSE "OK"

VARIABLES
    sent,     \* sent[i]: the i-th request submitted by the host (with its id)
    queue,    \* the bridge's response ring, in arrival order: entries
              \*   [id, status ("PENDING" or final), data]
    out,      \* the response stream the bridge has sent on the uplink, in order
    applied,  \* ghost: ids of write requests a node has stored in its inbox
    cause,    \* ghost: cause[id] = what really happened to request id
    full,     \* ghost: well-formed requests that found every data slot taken
    hostFrom, \* host: the oldest request it still has in flight.  Its in-flight
              \*   FIFO (ResponseMatcher.inflight) is hostFrom..Len(sent): it
              \*   only ever loses its head and gains a tail
    lastMatch, \* ghost: the host's latest match, [req: the request it completed
              \*   (or, for a placeholder, discarded the response of), resp: the
              \*   request the response answers] (0, 0 before any)
    timedOut, \* host: the placeholders, requests in flight that completed
              \*   UPLINK_TIMEOUT (or BRIDGE_LOST) and keep their sequence
              \*   numbers (Transfer.done)
    linkUp,   \* host: its uplink is open and not lost (lost_reason is None)
    forgotten, \* ghost: requests a bridge reset forgot (never answered)
    starts    \* host: the ids at which host processes began numbering (each
              \*   new process numbers its requests from 1: HostRestart)

hostVars == <<hostFrom, lastMatch, timedOut>>
vars == <<sent, queue, out, applied, cause, full, hostFrom, lastMatch, timedOut,
          linkUp, forgotten, starts>>

Entry == [id: 1..MaxReq, status: Statuses \cup {"PENDING"}, data: Seq(Nat)]
Response == [id: 1..MaxReq, seq: 0..SeqMod - 1, status: Statuses, data: Seq(Nat)]

DataSlotsUsed == Cardinality({k \in DOMAIN queue :
                               queue[k].status \notin AdmissionErrors})

TypeOK ==
    /\ sent \in Seq(Requests \X (1..MaxReq)) /\ Len(sent) <= MaxReq
    /\ queue \in Seq(Entry) /\ out \in Seq(Response)
    /\ applied \subseteq 1..MaxReq /\ full \subseteq 1..MaxReq
    /\ cause \in [1..MaxReq -> Statuses \cup {"NONE"}]
    /\ hostFrom \in 1..MaxReq + 1
    /\ lastMatch \in [req: 0..MaxReq, resp: 0..MaxReq]
    /\ timedOut \subseteq hostFrom..Len(sent)
    /\ linkUp \in BOOLEAN /\ forgotten \subseteq 1..Len(sent)
    /\ 1 \in starts /\ starts \subseteq 1..Len(sent) + 1

NoMatch == [req |-> 0, resp |-> 0]

(* The request ids held by a sequence of queue entries or responses.       *)
Ids(s) == {s[k].id : k \in DOMAIN s}

Init ==
    /\ sent = <<>> /\ queue = <<>> /\ out = <<>>
    /\ applied = {} /\ full = {}
    /\ cause = [i \in 1..MaxReq |-> "NONE"]
    /\ hostFrom = 1 /\ lastMatch = NoMatch /\ timedOut = {}
    /\ linkUp = TRUE /\ forgotten = {} /\ starts = {1}

Req(id) == sent[id][1]

(* The sequence number request id carries: each host process numbers its   *)
(* requests 1, 2, ... mod SeqMod (Rs232Core/UsbCore._next_seq) and the     *)
(* bridge echoes it.  Request id is the (id - ProcessStart(id) + 1)-th of  *)
(* its process.  A new start is above every id sent, so the number of a    *)
(* request sent never changes.  With one process (starts = {1}, every      *)
(* specification but SpecRestart) it is id % SeqMod, taken directly: the   *)
(* trace validation evaluates SeqOf for every response in every state, and *)
(* going through ProcessStart made a 1,400-event trace ~20% slower.        *)
ProcessStart(id) == CHOOSE s \in starts : s <= id /\ \A t \in starts : t <= id => t <= s
SeqOf(id) == IF starts = {1} THEN id % SeqMod
             ELSE (id - ProcessStart(id) + 1) % SeqMod

(* The host's requests in flight, oldest first. *)
InFlight == [k \in 1..Len(sent) - hostFrom + 1 |-> hostFrom + k - 1]

(***************************************************************************)
(* Host: receive response `resp` (ResponseMatcher.parse).  It is matched  *)
(* to the oldest request in flight (placeholders included) whose sequence *)
(* number it echoes; the requests before that one complete as lost, the  *)
(* placeholders before it are released (lost_before); matched to a        *)
(* placeholder, it is that request's late response, discarded (the      *)
(* request completed at its timeout).  A response whose sequence number  *)
(* no request in flight carries is discarded.  With UplinkLoss the        *)
(* response may instead be lost on the way.  While the host's uplink is   *)
(* closed (~linkUp) every response is lost: the port or device is closed, *)
(* bytes received while the core is lost count as stray                   *)
(* (Rs232Core.receive), and reopening drops what is buffered               *)
(* (open_serial: reset_input_buffer; ResponseMatcher.fail_all: rx).        *)
(***************************************************************************)
HostMatch(resp) ==
    LET F == InFlight
        ks == {k \in DOMAIN F : SeqOf(F[k]) = resp.seq}
    IN IF ks = {} THEN UNCHANGED hostVars
       ELSE LET k == CHOOSE k \in ks : \A j \in ks : k <= j IN
            /\ hostFrom' = F[k] + 1
            /\ lastMatch' = [req |-> F[k], resp |-> resp.id]
            /\ timedOut' = {i \in timedOut : i > F[k]}

HostReceives(resp) == IF ~linkUp THEN UNCHANGED hostVars
                      ELSE IF UplinkLoss THEN HostMatch(resp) \/ UNCHANGED hostVars
                      ELSE HostMatch(resp)

(***************************************************************************)
(* Host: submit a request, if fewer than HostWindow are outstanding.       *)
(* Bridge: admit it in the same step (the uplink is a FIFO; its delays are *)
(* the subject of UsbUplink).  Admission decides BAD_REQUEST,              *)
(* SIZE_MISMATCH and BUSY at once; otherwise the request takes a data      *)
(* slot and waits for the downlink.                                        *)
(***************************************************************************)
SubmitAndAdmit ==
    /\ linkUp                        \* a lost core sends nothing: a request
                                     \* submitted then completes BRIDGE_LOST
    /\ Len(sent) < MaxReq
    /\ Len(InFlight) < HostWindow    \* Rs232Core.frames_to_send: len(inflight) < window,
                                     \* placeholders included
    /\ \E r \in Requests :
         LET id == Len(sent) + 1
             st == IF AdmissionStatus(r) # "OK" THEN AdmissionStatus(r)
                   ELSE IF DataSlotsUsed >= QueueLen THEN "BUSY"
                   ELSE "PENDING"
         IN /\ sent' = Append(sent, <<r, id>>)
            /\ queue' = Append(queue, [id |-> id, status |-> st, data |-> NoData])
            /\ cause' = IF st = "PENDING" THEN cause ELSE [cause EXCEPT ![id] = st]
            \* the ghost records the CONDITION (well-formed, every data slot
            \* taken), not the answer, so BusyOnlyWhenFull checks the answer
            /\ full' = IF AdmissionStatus(r) = "OK" /\ DataSlotsUsed >= QueueLen
                         THEN full \cup {id} ELSE full
    /\ UNCHANGED <<out, applied, linkUp, forgotten, starts>> /\ UNCHANGED hostVars

(* Position k holds the oldest request still waiting for the downlink.    *)
OldestPending(k) == /\ queue[k].status = "PENDING"
                    /\ \A j \in 1..k - 1 : queue[j].status # "PENDING"
FirstPending == CHOOSE k \in DOMAIN queue : OldestPending(k)
HasPending == \E k \in DOMAIN queue : queue[k].status = "PENDING"

(***************************************************************************)
(* Bridge: one downlink transaction for the oldest pending request.  No    *)
(* acknowledge: NO_NODE.  Otherwise OK, or one of the faults: TIMEOUT (no  *)
(* answer in time), CHECKSUM (CRC mismatch; a node discards a corrupt      *)
(* write), BUS_STUCK (bus-clear performed), NODE_BUSY (write NACKed: both  *)
(* inbox buffers in use), NO_NODE (a node of Present acknowledged neither  *)
(* its address nor the bridge's probe after it: it vanished, or bit errors *)
(* hit both; Discovery.tla's NodeVanish as one request sees it).  A read   *)
(* returns the addressed outbox; a write stores into the addressed inbox.  *)
(* No retransmission.                                                      *)
(***************************************************************************)
Serve ==
    \E k \in DOMAIN queue :
       \* the oldest pending request (an existential, not CHOOSE: TLC's CHOOSE
       \* returns the smallest k, so a weakened "oldest" would go unnoticed)
       /\ OldestPending(k)
       /\ LET id == queue[k].id
              r == Req(id)
          IN \E st \in IF r.addr \notin Present THEN {"NO_NODE"}
                       ELSE {"OK"} \cup (Faults \ (IF r.op = "read"
                                                     THEN {"NODE_BUSY"} ELSE {})) :
               /\ queue' = [queue EXCEPT ![k] =
                      [id |-> id, status |-> st,
                       data |-> IF st = "OK" /\ r.op = "read"
                                  THEN Outbox(r.addr, r.box) ELSE NoData]]
               /\ applied' = IF st = "OK" /\ r.op = "write"
                               THEN applied \cup {id} ELSE applied
               /\ cause' = [cause EXCEPT ![id] = st]
       /\ UNCHANGED <<sent, out, full, linkUp, forgotten, starts>> /\ UNCHANGED hostVars

(***************************************************************************)
(* Bridge: the oldest response, once final, leaves on the uplink carrying *)
(* the request's sequence number; its slots are freed.  The host receives *)
(* it in the same step (the uplink is a FIFO; UsbUplink is about its       *)
(* delays).                                                                *)
(***************************************************************************)
Emit ==
    /\ queue # <<>> /\ Head(queue).status # "PENDING"
    /\ LET e == Head(queue)
           resp == [id |-> e.id, seq |-> SeqOf(e.id), status |-> e.status, data |-> e.data]
       IN /\ out' = Append(out, resp)
          /\ HostReceives(resp)
    /\ queue' = Tail(queue)
    /\ UNCHANGED <<sent, applied, cause, full, linkUp, forgotten, starts>>

(***************************************************************************)
(* Host: the oldest live request in flight got no response in time: it    *)
(* completes UPLINK_TIMEOUT (the application does not wait) but stays in  *)
(* flight as a placeholder, its sequence number reserved and its window   *)
(* slot taken (Rs232Core.poll, UsbCore.poll: ResponseMatcher.time_out).   *)
(* No premise: the bridge may still hold the request (a bridge slower     *)
(* than the host's 100 ms RS232 / 50 ms USB timeout).  Requests time out *)
(* in sending order (one timeout for all).  Explored where a response can *)
(* fail to come: with UplinkLoss for any request, else for a request a    *)
(* bridge reset forgot.  The mutant Bridge_TimeoutFreesSeq frees the      *)
(* number at once (the code before the fix).                               *)
(***************************************************************************)
HostTimeout ==
    /\ \E id \in hostFrom..Len(sent) :
         /\ UplinkLoss \/ id \in forgotten
         /\ id \notin timedOut
         /\ \A j \in hostFrom..id - 1 : j \in timedOut
         /\ timedOut' = timedOut \cup {id}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, hostFrom, lastMatch,
                   linkUp, forgotten, starts>>

(***************************************************************************)
(* Host: the oldest placeholder's lifetime is over (ResponseMatcher.expire:*)
(* placeholder_ns after it was sent): its number and window slot are      *)
(* free.  Premise: the lifetime outlasts the bridge's worst-case answer   *)
(* time, so it expires only once the bridge no longer holds the request   *)
(* (rs232_core.PLACEHOLDER_NS derives it from the firmware).  Placeholders *)
(* expire in sending order (one lifetime for all), the oldest first.  The *)
(* mutant Bridge_PlaceholderExpiresEarly drops the premise.  While the     *)
(* uplink is closed the code expires nothing until reset() expires every  *)
(* placeholder whose lifetime is over; the host does nothing else in       *)
(* between, so letting them expire one by one while ~linkUp is the same.  *)
(***************************************************************************)
HostExpire ==
    /\ hostFrom <= Len(sent) /\ hostFrom \in timedOut
    /\ hostFrom \notin Ids(queue)
    /\ hostFrom' = hostFrom + 1
    /\ timedOut' = timedOut \ {hostFrom}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, linkUp, forgotten,
                   starts>>

(***************************************************************************)
(* Host: the uplink is gone: close(), an I/O error, a silent bridge       *)
(* (Rs232Core/UsbCore.poll: lost_after) or the start of reconnect()       *)
(* (reset() calls link_lost first).  ResponseMatcher.fail_all: every live *)
(* request in flight completes BRIDGE_LOST and stays in flight as a       *)
(* placeholder, like a timed-out one (the bridge may still answer it);     *)
(* requests queued on the host complete BRIDGE_LOST unsent (not          *)
(* modelled: they were never sent), and so does every request submitted  *)
(* until the uplink is open again (SubmitAndAdmit needs linkUp).          *)
(***************************************************************************)
HostLinkLost ==
    /\ linkUp
    /\ linkUp' = FALSE
    /\ timedOut' = hostFrom..Len(sent)
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, hostFrom, lastMatch, forgotten,
                   starts>>

(***************************************************************************)
(* Host: reconnect() reopened the uplink (Rs232Core.reset, UsbCore.reset,  *)
(* via ThreadedManager._restart or _reopen_core; SimManager.reconnect).    *)
(* Reopening the port or device does not reset the bridge, which may      *)
(* still hold and later answer requests sent before: the placeholders     *)
(* stay (released as usual: a response, or their lifetime) and the        *)
(* numbering goes on (_next_seq is kept).  The mutant                      *)
(* Bridge_ReconnectClearsPlaceholders forgets them.                        *)
(***************************************************************************)
HostReopen ==
    /\ ~linkUp
    /\ linkUp' = TRUE
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, hostFrom, lastMatch, timedOut,
                   forgotten, starts>>

(***************************************************************************)
(* Host: a NEW host process opens the uplink after the previous one ended  *)
(* (HostLinkLost: it was killed, crashed, or closed without waiting for    *)
(* its answers; each `urb` CLI command is a new process,                   *)
(* cli_nodes.py).  The new core numbers its requests from 1 again          *)
(* (_next_seq) and knows nothing of the requests before it: its in-flight  *)
(* list is empty, with no placeholders.  The handover                      *)
(* (host/urb/managers/handover.py PortHandover; rs232_core.py              *)
(* MatchingCore.hand_over, usb_core.py UsbCore.hand_over): every process   *)
(* records on disk until when answers to its requests may still arrive     *)
(* (its newest request's sending + placeholder_ns); a new process opening  *)
(* the same port sends nothing and discards everything it receives until   *)
(* then, and on USB also until the bridge returns an empty IN batch        *)
(* (answers held in the bridge because nobody read them come out           *)
(* first).  By HostExpire's premise (the lifetime outlasts the bridge's    *)
(* worst-case answer time) the new process thus sends its first request    *)
(* only once the bridge holds no request of an earlier process: the guard  *)
(* queue = <<>>.  What the bridge sends before then is discarded: here it  *)
(* is emitted while ~linkUp, and lost (HostReceives).  The bridge is not   *)
(* touched.  The mutant Bridge_RestartWithoutHandover drops the guard (the *)
(* host library before the handover).                                      *)
(***************************************************************************)
HostRestart ==
    /\ ~linkUp
    /\ queue = <<>>
    /\ linkUp' = TRUE
    /\ hostFrom' = Len(sent) + 1
    /\ timedOut' = {}
    /\ starts' = starts \cup {Len(sent) + 1}
    /\ UNCHANGED <<sent, queue, out, applied, cause, full, lastMatch, forgotten>>

(***************************************************************************)
(* Bridge: reset or power loss.  It forgets every request it holds,        *)
(* pending or served but not yet answered (a response being sent is cut   *)
(* off: lost); nodes keep what they stored (applied).  Nothing tells the  *)
(* host: it times the forgotten requests out (HostTimeout), and their     *)
(* placeholders expire, the bridge no longer holding them (HostExpire).   *)
(* If the reset also drops the uplink (a USB device that disappears), the *)
(* host loses it and reconnects: HostLinkLost, HostReopen.                *)
(***************************************************************************)
BridgeReset ==
    /\ queue # <<>>
    /\ forgotten' = forgotten \cup Ids(queue)
    /\ queue' = <<>>
    /\ UNCHANGED <<sent, out, applied, cause, full, hostFrom, lastMatch, timedOut, linkUp,
                   starts>>

(* All requests submitted and answered: the run is over. *)
Done ==
    /\ Len(sent) = MaxReq /\ queue = <<>>
    /\ UNCHANGED vars

Next == SubmitAndAdmit \/ Serve \/ Emit \/ HostTimeout \/ HostExpire \/ Done

(* The bridge runs and the host times out and expires placeholders when   *)
(* it must: weak fairness (the host's timeouts and lifetimes are clocks).  *)
Fairness == /\ WF_vars(Serve) /\ WF_vars(Emit)
            /\ WF_vars(HostTimeout) /\ WF_vars(HostExpire)

Spec == Init /\ [][Next]_vars /\ Fairness

(* The host's uplink closes and reopens, any number of times (no fairness: *)
(* it may also stay closed).                                               *)
ReconnectNext == Next \/ HostLinkLost \/ HostReopen
SpecReconnect == Init /\ [][ReconnectNext]_vars /\ Fairness

(* The bridge resets, and the host may lose and reopen its uplink too.     *)
ResetNext == ReconnectNext \/ BridgeReset
SpecReset == Init /\ [][ResetNext]_vars /\ Fairness

(* A new host process takes the uplink over after the previous one ended, *)
(* and a process may lose and reopen its uplink (no bridge reset).         *)
RestartNext == ReconnectNext \/ HostRestart
SpecRestart == Init /\ [][RestartNext]_vars /\ Fairness

-----------------------------------------------------------------------------
Answered(id) == \E k \in DOMAIN out : out[k].id = id

(* No two entries of s hold the same id: as many distinct ids as entries.  *)
DistinctIds(s) == Cardinality(Ids(s)) = Len(s)

(* The ids of s never decrease: each is >= the one before (<= is          *)
(* transitive, so every pair of entries is in order).                     *)
IdsInOrder(s) == \A k \in 1..Len(s) - 1 : s[k].id <= s[k + 1].id

(* Trace validation (sim/tla/TraceBridge.tla) checks the invariants below  *)
(* on states holding hundreds of responses, so they quantify over one     *)
(* entry at a time: the pairwise statements took 4x longer there.  The    *)
(* two helpers above equal the pairwise statements (MCBridge.tla checks   *)
(* it on every short sequence).                                            *)

(* Nothing is dropped: every submitted request is in the bridge or         *)
(* answered, or was forgotten in a bridge reset.                           *)
\* lobster-trace: urb.ORD_001
NoSilentDrop == 1..Len(sent) \subseteq Ids(out) \cup Ids(queue) \cup forgotten

(* No request is answered twice. *)
\* lobster-trace: urb.ORD_002
AtMostOneResponse == DistinctIds(out)

(* Responses leave in request order. *)
\* lobster-trace: urb.ORD_003
ResponsesInRequestOrder == IdsInOrder(out)

(* The k-th response answers the k-th request (of those no bridge reset   *)
(* forgot: with no reset, simply the k-th) and echoes its sequence        *)
(* number; a successful read carries the addressed outbox's data, any      *)
(* other response carries no data.                                         *)
\* lobster-trace: urb.ORD_004
ResponseMatchesRequest ==
    \A k \in DOMAIN out :
        LET id == out[k].id
            r == Req(id) IN
        /\ id - Cardinality({i \in forgotten : i < id}) = k
        /\ out[k].seq = SeqOf(id)
        /\ out[k].data = IF out[k].status = "OK" /\ r.op = "read"
                           THEN Outbox(r.addr, r.box) ELSE NoData

(* An error response names what really happened. *)
\* lobster-trace: urb.ERR_001
ErrorNamesCause ==
    \A k \in DOMAIN out : out[k].status # "OK" => out[k].status = cause[out[k].id]

(* OK for a write means the node stored it; a write answered CHECKSUM,     *)
(* NODE_BUSY, NO_NODE or an admission error was not stored.  (TIMEOUT and  *)
(* BUS_STUCK leave it unknown: the host must not assume either.)           *)
\* lobster-trace: urb.ERR_002
WriteStatusTruthful ==
    \A k \in DOMAIN out :
        Req(out[k].id).op = "write" =>
           /\ out[k].status = "OK" => out[k].id \in applied
           /\ out[k].status \in {"CHECKSUM", "NODE_BUSY", "NO_NODE"} \cup AdmissionErrors
                 => out[k].id \notin applied

(* The downlink serves requests in the order they arrived: no request is   *)
(* served while an earlier one still waits, so two writes to one inbox     *)
(* land in the order the host sent them.  (Admission answers, BUSY,        *)
(* SIZE_MISMATCH and BAD_REQUEST, never reach the downlink.)  Responses in *)
(* request order (ResponsesInRequestOrder) do not imply it: the ring sends *)
(* them in arrival order whatever order the downlink served them in.      *)
\* lobster-trace: urb.ORD_003
ServedInArrivalOrder ==
    \A j, k \in DOMAIN queue :
        j < k /\ queue[j].status = "PENDING"
            => queue[k].status \in {"PENDING"} \cup AdmissionErrors

(* NODE_BUSY (the node NACKed: both inbox buffers in use) answers writes   *)
(* only: a node never refuses a read of its outbox (its ISR never waits,    *)
(* MailboxOutbox.tla).                                                      *)
\* lobster-trace: urb.ERR_001
NodeBusyOnlyForWrites ==
    \A k \in DOMAIN out : out[k].status = "NODE_BUSY" => Req(out[k].id).op = "write"

(* BUSY is only answered when every data slot was taken. *)
\* lobster-trace: urb.ORD_005
BusyOnlyWhenFull ==
    \A k \in DOMAIN out : out[k].status = "BUSY" => out[k].id \in full

(* The response ring never holds more than HostWindow entries, and the    *)
(* data slots never more than QueueLen.                                    *)
\* lobster-trace: urb.RES_003
BoundedMemory == Len(queue) <= HostWindow /\ DataSlotsUsed <= QueueLen

(* What the host relies on, across sequence-number wrap: a response it     *)
(* matches (by sequence number, oldest first, within its window) is the   *)
(* response to the request it completes with it (or, for a placeholder,   *)
(* discards as that request's late response), never an older or a newer  *)
(* request's, whatever the bridge still holds when the host times out.    *)
(* Checked in the state after every match.                                 *)
\* lobster-trace: urb.HOST_002
NoSeqAliasing == lastMatch.req = lastMatch.resp

(* Liveness: every submitted request is eventually answered, unless a     *)
(* bridge reset forgot it:                                                  *)
(*     \A id \in 1..MaxReq : (id <= Len(sent)) ~> (Answered(id) \/ id \in forgotten) *)
(* stated as: again and again, every request sent so far is answered or    *)
(* forgotten.  The two are equivalent here: no action ever shrinks sent,   *)
(* out or forgotten, and at most MaxReq requests are sent, so once each   *)
(* request is answered or forgotten it stays so, and after the last send  *)
(* all are at once; conversely, a request sent before such a moment is    *)
(* answered or forgotten at it.  TLC checks the one formula with one      *)
(* tableau instead of one per request: 4.4 s instead of 30 s of CPU for    *)
(* a 5-request MCBridgeRestart (issue #37's mutation runs).                *)
\* lobster-trace: urb.ORD_006
EveryRequestAnswered ==
    []<>(\A id \in 1..Len(sent) : Answered(id) \/ id \in forgotten)

(* Liveness: the host never waits forever.  Every request it sent leaves  *)
(* its in-flight list (answered, passed by a later response, or its       *)
(* placeholder expired) and gives its window slot back, whatever was lost *)
(* on the uplink or forgotten by a bridge reset:                            *)
(*     \A id \in 1..MaxReq : (id <= Len(sent)) ~> (hostFrom > id)           *)
(* stated as: again and again, nothing is in flight.  Equivalent as above: *)
(* hostFrom never decreases (a match moves it past the matched request, an *)
(* expiry by one, a new process past every request sent).                  *)
\* lobster-trace: urb.FLT_005
EveryRequestReleased == []<>(hostFrom > Len(sent))

(* Safety of the host's releases: a request leaves the host's in-flight   *)
(* list only once it has completed: as a placeholder (it timed out or its *)
(* uplink was lost: its callback ran) or by a response matched to it or to *)
(* a later request (lost_before completes the ones it passes).  Without it *)
(* a host that frees a live request whose response was lost passes every  *)
(* other property: the request never completes, and EveryRequestReleased  *)
(* holds all the same (issue #37's mutation run: HostExpire without its   *)
(* premise hostFrom \in timedOut).  The mutant Bridge_ExpireLiveRequest.  *)
\* lobster-trace: urb.HOST_001
HostReleasesOnlyCompleted ==
    [][\A i \in hostFrom..(hostFrom' - 1) : i \in timedOut \/ i <= lastMatch'.req]_vars

-----------------------------------------------------------------------------
(***************************************************************************)
(* Reachability witnesses: situations a model must reach, so that no       *)
(* invariant above holds only because its situation never arises.         *)
(* spec/tla/manifest.json lists, per model, the ones it must reach; the    *)
(* model-check runner fails the model when one is not (tools/             *)
(* tla_witness.py).                                                         *)
(***************************************************************************)
Answers(s) == \E k \in DOMAIN out : out[k].status = s
ReachOkAnswer == Answers("OK")
ReachTimeoutAnswer == Answers("TIMEOUT")
ReachChecksumAnswer == Answers("CHECKSUM")
ReachBusStuckAnswer == Answers("BUS_STUCK")
ReachNodeBusyAnswer == Answers("NODE_BUSY")
ReachNoNodeAnswer == Answers("NO_NODE")
ReachBusyAnswer == Answers("BUSY")
ReachSizeMismatchAnswer == Answers("SIZE_MISMATCH")
ReachBadRequestAnswer == Answers("BAD_REQUEST")
(* an OK read carrying its mailbox's data; a write a node stored *)
ReachReadData == \E k \in DOMAIN out : out[k].status = "OK" /\ out[k].data # NoData
ReachWriteStored == applied # {}
(* two requests wait for the downlink at once: the order it serves them in matters *)
ReachTwoPending == Cardinality({k \in DOMAIN queue : queue[k].status = "PENDING"}) >= 2
(* every data slot taken; the response ring full; the host's window full *)
ReachDataSlotsFull == DataSlotsUsed = QueueLen
ReachRingFull == Len(queue) = HostWindow
ReachWindowFull == Len(InFlight) = HostWindow
ReachAllAnswered == Len(out) = MaxReq
(* a request numbered after the sequence number wrapped is matched *)
ReachSeqWrap == lastMatch.req > SeqMod
(* a response was lost: it left the bridge, its request is still in flight *)
ReachLostResponse == \E k \in DOMAIN out : out[k].id >= hostFrom
(* placeholders: one exists; the bridge still holds one; its late response *)
(* is next on the uplink; a response to a later request is next and        *)
(* passes it; one can expire; the window is full of them                   *)
ReachPlaceholder == timedOut # {}
ReachPlaceholderHeld == timedOut \cap Ids(queue) # {}
NextOut == linkUp /\ queue # <<>> /\ Head(queue).status # "PENDING"
ReachLateResponse == NextOut /\ Head(queue).id \in timedOut
ReachPlaceholderPassed == NextOut /\ \E id \in timedOut : id < Head(queue).id
ReachPlaceholderExpiry == ENABLED HostExpire
ReachWindowOfPlaceholders == Len(InFlight) = HostWindow /\ timedOut = hostFrom..Len(sent)
(* the uplink is lost with requests the bridge still holds, and a response *)
(* leaves while it is closed (lost)                                         *)
ReachLinkLost == ~linkUp /\ timedOut \cap Ids(queue) # {}
ReachSentWhileClosed == ~linkUp /\ queue # <<>> /\ Head(queue).status # "PENDING"
(* a bridge reset forgot a request; the host timed one out; its           *)
(* placeholder can expire; a later request is answered after the reset    *)
ReachReset == forgotten # {}
ReachForgottenTimedOut == forgotten \cap timedOut # {}
ReachForgottenExpiry == hostFrom \in forgotten /\ ENABLED HostExpire
ReachAnsweredAfterReset == \E k \in DOMAIN out : \E f \in forgotten : out[k].id > f
(* a new host process began numbering; one of its requests is matched;    *)
(* a new process can start while the previous one left placeholders       *)
ReachNewProcess == Cardinality(starts) >= 2
ReachNewProcessMatched == \E s \in starts : s > 1 /\ lastMatch.req >= s
ReachRestartOverPlaceholders == timedOut # {} /\ ENABLED HostRestart

THEOREM Spec => [](TypeOK /\ NoSilentDrop /\ AtMostOneResponse
                          /\ ResponsesInRequestOrder /\ ResponseMatchesRequest
                          /\ ErrorNamesCause /\ WriteStatusTruthful /\ NodeBusyOnlyForWrites
                          /\ ServedInArrivalOrder /\ BusyOnlyWhenFull /\ BoundedMemory
                          /\ NoSeqAliasing)
THEOREM Spec => EveryRequestAnswered /\ EveryRequestReleased
THEOREM SpecReset => [](TypeOK /\ NoSilentDrop /\ AtMostOneResponse
                          /\ ResponsesInRequestOrder /\ ResponseMatchesRequest
                          /\ ErrorNamesCause /\ WriteStatusTruthful /\ NodeBusyOnlyForWrites
                          /\ ServedInArrivalOrder /\ BusyOnlyWhenFull /\ BoundedMemory
                          /\ NoSeqAliasing)
THEOREM SpecReset => EveryRequestAnswered /\ EveryRequestReleased
THEOREM SpecRestart => [](TypeOK /\ NoSilentDrop /\ AtMostOneResponse
                          /\ ResponsesInRequestOrder /\ ResponseMatchesRequest
                          /\ ErrorNamesCause /\ WriteStatusTruthful /\ NodeBusyOnlyForWrites
                          /\ ServedInArrivalOrder /\ BusyOnlyWhenFull /\ BoundedMemory
                          /\ NoSeqAliasing)
THEOREM SpecRestart => EveryRequestAnswered /\ EveryRequestReleased
=============================================================================
