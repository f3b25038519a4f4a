--------------------------- MODULE TraceDiscovery ---------------------------
(***************************************************************************)
(* Trace validation of discovery against Discovery.tla.                     *)
(*                                                                         *)
(* The wiring (which node sits at which bridge and address, with the       *)
(* identity it reports) is the simulated system's, so Init's choice of pop *)
(* is fixed to it.  The host library's discovery is logged (turned into    *)
(* the constant Trace by sim/urb_sim/tracecheck.py) as:                   *)
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
(* (MaxChurn).  Accepted when a state matches every event (l - 1 =        *)
(* Len(Trace); urb_sim/tracebatch.py prints every state's l - 1).         *)
(* Every invariant of Discovery.tla is checked on the way.                 *)
(***************************************************************************)
EXTENDS Discovery, Sequences

CONSTANTS Trace,        \* the logged events (from sim/urb_sim/tracecheck.py)
          TWired,       \* the system's wiring: slot -> identity
          TChurnSlots   \* the slots whose power the scenario switched

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

=============================================================================
