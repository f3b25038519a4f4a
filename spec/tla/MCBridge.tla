------------------------------- MODULE MCBridge -------------------------------
(* Model values for Bridge: node 1 on the bus (outbox/inbox 1 of 2 bytes), *)
(* address 2 absent.  Requests: a good read and a good write to node 1, a  *)
(* read of the absent node, a wrong length and a bad mailbox number.       *)
EXTENDS Bridge

MCPresent == {1}
MCSize == [n \in {1} |-> [b \in 0..7 |-> 2]]
MCRequests ==
    { [addr |-> 1, box |-> 1, op |-> "read",  len |-> 2],
      [addr |-> 1, box |-> 1, op |-> "write", len |-> 2],
      [addr |-> 2, box |-> 1, op |-> "read",  len |-> 2],
      [addr |-> 1, box |-> 1, op |-> "read",  len |-> 3],
      [addr |-> 1, box |-> 9, op |-> "write", len |-> 2] }
(* For the larger opt-in configuration: well-formed requests only (the    *)
(* admission errors do not interact with the FIFO depth).                  *)
MCRequestsCore ==
    { [addr |-> 1, box |-> 1, op |-> "read",  len |-> 2],
      [addr |-> 1, box |-> 1, op |-> "write", len |-> 2],
      [addr |-> 2, box |-> 1, op |-> "read",  len |-> 2] }
MCFaults == {"TIMEOUT", "CHECKSUM", "BUS_STUCK", "NODE_BUSY", "NO_NODE"}
(* For the sequence-number wrap (MCBridgeWrap.cfg: SeqMod 4, more than     *)
(* SeqMod requests, lost responses, host timeouts): the host's matching    *)
(* does not look at the request's kind or outcome, so one good read, no    *)
(* downlink fault and as many data slots as the window (no BUSY) keep the  *)
(* state space small: every response is OK, the runs differ in timing,    *)
(* lost responses and host timeouts.                                       *)
MCRequestsWrap == { [addr |-> 1, box |-> 1, op |-> "read",  len |-> 2] }
MCFaultsWrap == {}

(* For the bridge reset (MCBridgeReset.cfg: the wrap's constants, 6        *)
(* requests, lost responses): Bridge's SpecReset with at most one          *)
(* bridge reset per behaviour (and any number of reconnects).  A reset     *)
(* leaves the bridge as Init does; unbounded resets multiply the histories *)
(* of answered and forgotten requests for no new kind of host state        *)
(* (60,257 states: the opt-in MCBridgeResetLarge.cfg).                     *)
MCResetNext == ReconnectNext \/ (forgotten = {} /\ BridgeReset)
MCSpecReset == Init /\ [][MCResetNext]_vars /\ Fairness

(* Bridge.tla states AtMostOneResponse and ResponsesInRequestOrder with    *)
(* one quantifier (DistinctIds, IdsInOrder) for speed.  Each must equal    *)
(* its pairwise statement: checked on every sequence of up to 4 entries    *)
(* over the ids 1..3 (the mutants Bridge_DistinctByCount and               *)
(* Bridge_OrderSkipsLastPair show the check failing).                      *)
Entries(ids) == [k \in DOMAIN ids |-> [id |-> ids[k]]]
FormsAgree(Distinct(_), InOrder(_)) ==
    \A o \in UNION {[1..m -> 1..3] : m \in 0..4} :
        /\ Distinct(Entries(o)) <=> \A k, j \in DOMAIN o : k # j => o[k] # o[j]
        /\ InOrder(Entries(o)) <=> \A k, j \in DOMAIN o : k < j => o[k] <= o[j]
ASSUME FormsAgree(DistinctIds, IdsInOrder)

(* The header limits (mailbox 0..7, length 1..32: spec/schema) restated    *)
(* for every mailbox 0..9 and length 0..34 with other operators than       *)
(* AdmissionStatus uses.  The model's requests probe one bad mailbox (9)   *)
(* and one wrong length (3), not the boundaries; this pins them (the       *)
(* mutant Bridge_MailboxLimitOffByOne and the mutation run's off-by-one    *)
(* mutants of AdmissionStatus make it false).  Node 2 is absent, so only   *)
(* the header decides.                                                     *)
HeaderLimitsAgree(Admit(_)) ==
    \A box \in 0..9, len \in 0..34 :
        (Admit([addr |-> 2, box |-> box, op |-> "read", len |-> len]) = "BAD_REQUEST")
            <=> ~(box >= 0 /\ box < 8 /\ len > 0 /\ len < 33)
ASSUME HeaderLimitsAgree(AdmissionStatus)
=============================================================================
