--------------------------- MODULE TraceDiscovery ---------------------------
(***************************************************************************)
(* Trace validation of discovery against Discovery.tla.                     *)
(*                                                                         *)
(* The wiring (which node sits at which bridge and address, with the       *)
(* identity it reports) is the simulated system's, so Init's choice of pop *)
(* is fixed to it.  The host library's discovery is logged (turned into    *)
(* the module TraceDiscoveryData by sim/urb_sim/tracecheck.py) as:        *)
(*   [ev |-> "scan", bridge, addr, found]  the bridge's scan and the host's *)
(*                                     identification read of one address, *)
(*                                     every address 1..NAddr of every      *)
(*                                     bridge in increasing order: found is *)
(*                                     {} (no answer) or {[addr, id]}:      *)
(*                                     ScanAddress                          *)
(*   [ev |-> "table", rows]            the host's system table when every  *)
(*                                     bridge is done, with each row's      *)
(*                                     DUPLICATE and MISMATCH flags:        *)
(*                                     HostBuildTable                       *)
(*   [ev |-> "request", bridge, addr, status]  a request to a table row and *)
(*                                     its outcome, OK or NO_NODE:          *)
(*                                     HostRequest                          *)
(* Not logged: nodes vanishing and reappearing (NodeVanish, NodeAppear).   *)
(* TLC places them wherever the trace allows, on the slots whose power the *)
(* scenario switched (TChurnSlots) and at most as often as it did          *)
(* (MaxChurn).  Accepted when a state matches every event: MatchedSoFar   *)
(* prints each new longest matched prefix, <<"matched", Len(Trace)>> last. *)
(* Every invariant of Discovery.tla is checked on the way.                 *)
(***************************************************************************)
EXTENDS Discovery, TraceDiscoveryData, TLC

VARIABLE l   \* index of the next logged event to match

tvars == <<vars, l>>

(* The system's wiring: TWired maps the wired slots to their identities. *)
Wiring == [s \in Slots |-> IF s \in DOMAIN TWired THEN TWired[s] ELSE NONE]

TraceInit == pop = Wiring /\ Init /\ l = 1

MatchScan ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "scan"
    /\ cursor[Trace[l].bridge] = Trace[l].addr
    /\ ScanAddress(Trace[l].bridge)
    /\ found'[Trace[l].bridge] \ found[Trace[l].bridge] = Trace[l].found
    /\ l' = l + 1

MatchTable ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "table"
    /\ HostBuildTable
    /\ table' = Trace[l].rows
    /\ l' = l + 1

MatchRequest ==
    /\ l <= Len(Trace) /\ Trace[l].ev = "request"
    /\ HostRequest
    /\ lastReq'.slot = <<Trace[l].bridge, Trace[l].addr>>
    /\ lastReq'.status = Trace[l].status
    /\ l' = l + 1

Hidden ==
    /\ l <= Len(Trace)
    /\ \E s \in TChurnSlots : NodeVanish(s) \/ NodeAppear(s)
    /\ UNCHANGED l

TraceNext == MatchScan \/ MatchTable \/ MatchRequest \/ Hidden

(* Not a property (always TRUE): TLC register 1 holds the longest prefix  *)
(* matched in any state seen so far, and each new one is printed as       *)
(* <<"matched", n>> (tracecheck.py reads the last).                        *)
ASSUME TLCSet(1, 0)
MatchedSoFar ==
    IF l - 1 > TLCGet(1) THEN TLCSet(1, l - 1) /\ PrintT(<<"matched", l - 1>>) ELSE TRUE
=============================================================================
