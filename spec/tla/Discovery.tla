------------------------------- MODULE Discovery -------------------------------
(***************************************************************************)
(* Node discovery and identification (paper Sec. IV-A, IV-C, Fig. 3).       *)
(*                                                                         *)
(* Each bridge scans its downlink addresses in increasing order and reads  *)
(* outbox 0 of every address that acknowledges; the node reports its      *)
(* 8-bit class, 6-bit index and the fingerprint of its mailbox layout.     *)
(* When all bridges have finished, the host (URBInterface) builds one      *)
(* system table with one row per answering (bridge, address): rows are    *)
(* never merged; two rows with the same (class, index) anywhere in the    *)
(* system are both flagged DUPLICATE; a fingerprint that differs from the *)
(* host's expected one for that class is flagged MISMATCH.  Nodes may     *)
(* appear or vanish at any moment (loose connector, brown-out); a node    *)
(* that vanishes after being read stays in the table (present at scan),   *)
(* and later requests to it are answered NO_NODE.                          *)
(***************************************************************************)
EXTENDS Naturals, FiniteSets

CONSTANTS
    Bridges,     \* bridges registered with addBusManager()
    NAddr,       \* addresses 1..NAddr scanned on every downlink
    Idents,      \* identities a node may have: [class, index, fp]
    Expected,    \* Expected[class]: layout fingerprint the host was built with
    MaxChurn,    \* number of appear/vanish events in a behaviour
    NONE         \* no node at this address

ASSUME /\ \A i \in Idents : i.class \in 0..255 /\ i.index \in 0..63
       /\ NAddr \in Nat \ {0} /\ MaxChurn \in Nat

Addrs == 1..NAddr
Slots == Bridges \X Addrs
Row == [bridge: Bridges, addr: Addrs, class: 0..255, index: 0..63, fp: STRING,
        flags: SUBSET {"DUPLICATE", "MISMATCH"}]

VARIABLES
    pop,        \* pop[s]: the node wired at slot s, or NONE (fixed)
    present,    \* present[s]: that node currently acknowledges its address
    churn,      \* appear/vanish events so far
    cursor,     \* cursor[b]: next address bridge b will scan (NAddr+1: done)
    found,      \* found[b]: bridge b's table: set of [addr, id]
    table,      \* host's system table (set of Row); valid once built
    built,      \* the host has built its table
    stable,     \* ghost: slots whose node was present throughout the scan
    lastReq     \* last post-scan request: [slot, status, present] or NONE

vars == <<pop, present, churn, cursor, found, table, built, stable, lastReq>>

TypeOK ==
    /\ pop \in [Slots -> Idents \cup {NONE}]
    /\ present \in [Slots -> BOOLEAN] /\ churn \in 0..MaxChurn
    /\ cursor \in [Bridges -> 1..NAddr + 1]
    /\ found \in [Bridges -> SUBSET [addr: Addrs, id: Idents]]
    /\ table \subseteq Row /\ built \in BOOLEAN /\ stable \subseteq Slots

Init ==
    /\ pop \in [Slots -> Idents \cup {NONE}]
    /\ present = [s \in Slots |-> pop[s] # NONE]
    /\ churn = 0
    /\ cursor = [b \in Bridges |-> 1]
    /\ found = [b \in Bridges |-> {}]
    /\ table = {} /\ built = FALSE
    /\ stable = {s \in Slots : pop[s] # NONE}
    /\ lastReq = NONE

(***************************************************************************)
(* Environment: a node vanishes from / reappears on its downlink.          *)
(***************************************************************************)
NodeVanish(s) ==
    /\ pop[s] # NONE /\ present[s] /\ churn < MaxChurn
    /\ present' = [present EXCEPT ![s] = FALSE] /\ churn' = churn + 1
    /\ stable' = stable \ {s}
    /\ UNCHANGED <<pop, cursor, found, table, built, lastReq>>

NodeAppear(s) ==
    /\ pop[s] # NONE /\ ~present[s] /\ churn < MaxChurn
    /\ present' = [present EXCEPT ![s] = TRUE] /\ churn' = churn + 1
    /\ UNCHANGED <<pop, cursor, found, table, built, stable, lastReq>>

(***************************************************************************)
(* Bridge b probes its next address.  Acknowledged: read outbox 0 and add  *)
(* (address, class, index, fingerprint) to its table.  Not acknowledged    *)
(* (NO_NODE): nothing is added and the scan goes on to the next address;   *)
(* a gap never ends the scan.                                              *)
(***************************************************************************)
ScanAddress(b) ==
    /\ cursor[b] <= NAddr
    /\ LET s == <<b, cursor[b]>> IN
         found' = IF present[s]
                    THEN [found EXCEPT ![b] = @ \cup {[addr |-> cursor[b], id |-> pop[s]]}]
                    ELSE found
    /\ cursor' = [cursor EXCEPT ![b] = @ + 1]
    /\ UNCHANGED <<pop, present, churn, table, built, stable, lastReq>>

ScanDone == \A b \in Bridges : cursor[b] = NAddr + 1

AllFound == UNION { { [bridge |-> b, addr |-> f.addr, id |-> f.id] : f \in found[b] }
                    : b \in Bridges }

Flags(f) ==
    (IF \E g \in AllFound : g # f /\ g.id.class = f.id.class /\ g.id.index = f.id.index
       THEN {"DUPLICATE"} ELSE {})
    \cup (IF f.id.fp # Expected[f.id.class] THEN {"MISMATCH"} ELSE {})

ToRow(f) == [bridge |-> f.bridge, addr |-> f.addr, class |-> f.id.class,
             index |-> f.id.index, fp |-> f.id.fp, flags |-> Flags(f)]

(***************************************************************************)
(* Host: once every bridge has scanned, build the system table: one row   *)
(* per (bridge, address) that answered, with its DUPLICATE / MISMATCH      *)
(* flags.  findNode(class, index) refuses a DUPLICATE or MISMATCH row.     *)
(***************************************************************************)
HostBuildTable ==
    /\ ScanDone /\ ~built
    /\ table' = { ToRow(f) : f \in AllFound }
    /\ built' = TRUE
    /\ UNCHANGED <<pop, present, churn, cursor, found, stable, lastReq>>

(***************************************************************************)
(* After discovery the host sends a request to a node of its table; the   *)
(* bridge answers NO_NODE if the address is not acknowledged any more.     *)
(***************************************************************************)
HostRequest ==
    /\ built
    /\ \E r \in table :
         LET s == <<r.bridge, r.addr>> IN
         lastReq' = [slot |-> s, present |-> present[s],
                     status |-> IF present[s] THEN "OK" ELSE "NO_NODE"]
    /\ UNCHANGED <<pop, present, churn, cursor, found, table, built, stable>>

(* Discovery is over; the host keeps running (no deadlock in the model).  *)
HostIdle == built /\ UNCHANGED vars

Next == \/ \E s \in Slots : NodeVanish(s) \/ NodeAppear(s)
        \/ \E b \in Bridges : ScanAddress(b)
        \/ HostBuildTable \/ HostRequest \/ HostIdle

Spec == Init /\ [][Next]_vars
        /\ \A b \in Bridges : WF_vars(ScanAddress(b))
        /\ WF_vars(HostBuildTable)

-----------------------------------------------------------------------------
RowSlots == { <<r.bridge, r.addr>> : r \in table }
FoundSlots == { <<f.bridge, f.addr>> : f \in AllFound }

(* Rows are never merged: one row per answering (bridge, address).         *)
\* lobster-trace: urb.DSC_001
NeverMerged == built => (RowSlots = FoundSlots /\ Cardinality(table) = Cardinality(AllFound))

(* Same (class, index) twice in the system: every such row says DUPLICATE. *)
\* lobster-trace: urb.DSC_002
DuplicatesReported ==
    \A r \in table :
        ("DUPLICATE" \in r.flags) <=>
            \E q \in table : q # r /\ q.class = r.class /\ q.index = r.index

(* A fingerprint other than the expected one for the class: MISMATCH.     *)
\* lobster-trace: urb.DSC_003
MismatchReported ==
    \A r \in table : ("MISMATCH" \in r.flags) <=> (r.fp # Expected[r.class])

(* No phantom: every row is the node wired at that slot, as it reported.   *)
\* lobster-trace: urb.DSC_004
NoPhantoms ==
    \A r \in table : LET s == <<r.bridge, r.addr>> IN
        /\ pop[s] # NONE
        /\ pop[s].class = r.class /\ pop[s].index = r.index /\ pop[s].fp = r.fp

(* A node that answered the scan keeps its row even if it has vanished    *)
(* since (present at scan; requests to it then get NO_NODE).              *)
\* lobster-trace: urb.DSC_006
VanishedNodesKept ==
    built => \A f \in AllFound : ~present[<<f.bridge, f.addr>>] =>
                 <<f.bridge, f.addr>> \in RowSlots

(* A node present during the whole scan is in the table.                  *)
\* lobster-trace: urb.DSC_005
StableNodesFound == built => \A s \in stable : s \in RowSlots

(* Requests to a vanished node are answered NO_NODE, to a present one not. *)
\* lobster-trace: urb.DSC_006
VanishedGetNoNode ==
    lastReq # NONE => ((lastReq.status = "NO_NODE") <=> ~lastReq.present)

(* Liveness: discovery terminates with a table, whatever the churn.       *)
\* lobster-trace: urb.DSC_007
DiscoveryCompletes == <>built

-----------------------------------------------------------------------------
(* Reachability witnesses (spec/tla/manifest.json lists them per model).   *)
Flagged(r, f) == f \in r.flags
ReachDuplicate == \E r \in table : Flagged(r, "DUPLICATE")
ReachDuplicateAcrossBridges ==
    \E r, q \in table : r.bridge # q.bridge /\ r.class = q.class /\ r.index = q.index
ReachMismatch == \E r \in table : Flagged(r, "MISMATCH")
ReachDuplicateAndMismatch == \E r \in table : Flagged(r, "DUPLICATE") /\ Flagged(r, "MISMATCH")
(* not duplicates: the same class with another index, the same index of   *)
(* another class (a duplicate test that ignores one of them flags these)  *)
ReachSameClassOtherIndex == \E r, q \in table : r.class = q.class /\ r.index # q.index
ReachSameIndexOtherClass == \E r, q \in table : r.class # q.class /\ r.index = q.index
(* a node with the layout another class expects (a fingerprint check      *)
(* against the wrong class passes it)                                      *)
ReachOtherClassLayout ==
    \E r \in table : r.fp # Expected[r.class] /\ \E c \in DOMAIN Expected : r.fp = Expected[c]
ReachNoNode == lastReq # NONE /\ lastReq.status = "NO_NODE"
ReachVanishedKept == built /\ \E r \in table : ~present[<<r.bridge, r.addr>>]
(* a scan went past an address that did not answer and found a node after it *)
ReachGapInScan ==
    \E r \in table : \E a \in Addrs : a < r.addr /\ <<r.bridge, a>> \notin RowSlots
(* a node missed by the scan (it vanished before its address was read)    *)
ReachMissedByScan == built /\ \E s \in Slots : pop[s] # NONE /\ s \notin RowSlots
(* a node that vanished came back and is in the table (found before it   *)
(* vanished or after it came back): reappearing is part of the churn       *)
ReachReappearedInTable == built /\ \E s \in RowSlots : s \notin stable /\ present[s]

THEOREM Spec => [](TypeOK /\ NeverMerged /\ DuplicatesReported /\ MismatchReported
                          /\ NoPhantoms /\ VanishedNodesKept /\ StableNodesFound
                          /\ VanishedGetNoNode)
THEOREM Spec => DiscoveryCompletes
=============================================================================
