---------------------------- MODULE MailboxOutbox ----------------------------
(***************************************************************************)
(* One double-buffered OUTBOX of a URB node (paper Sec. IV-A, Fig. 2).      *)
(*                                                                         *)
(* Writer: the node application (URB_LockOutbox / URB_ReleaseOutbox).      *)
(* Reader: the downlink interrupt (ISR) that answers a bridge read.        *)
(* The ISR is never preempted by the application; the application can be  *)
(* preempted by the ISR between any two of its steps, and one bus read     *)
(* spans several ISR invocations (one per I2C byte), so the application    *)
(* runs between them.  Every step below is ONE memory access of the        *)
(* firmware (a load or a store of a shared variable, or one byte copy);    *)
(* the firmware implements each action as written and cites its name.      *)
(*                                                                         *)
(* Shared variables (two buffers, index variables):                        *)
(*   front   : buffer holding the latest released message; written only   *)
(*             by the application (one single store on release).          *)
(*   isr_idx : buffer the ISR is copying from, NONE when idle; written     *)
(*             only by the ISR.                                            *)
(* Bytes are modelled as the id of the write that stored them, so a torn   *)
(* read (bytes of two writes) is visible.                                  *)
(***************************************************************************)
EXTENDS Naturals, Sequences

CONSTANTS
    MsgLen,     \* bytes per message (>= 2 so that tearing is observable)
    MaxWrites   \* number of application writes (releases) explored

ASSUME MsgLen \in Nat \ {0, 1} /\ MaxWrites \in Nat \ {0}

NONE == 2           \* index value meaning "no buffer" (fits the C uint8_t)
Bufs == {0, 1}
Tags == 0..MaxWrites \* write ids; 0 = the value set up by URB_SetupOutbox

VARIABLES
    buf,      \* buf[i][k]: write id of byte k of buffer i
    front,    \* shared: latest released buffer (app writes, ISR reads)
    isrIdx,   \* shared: buffer the ISR is reading, or NONE (ISR writes, app reads)
    appPc,    \* application program counter
    w,        \* application local: the buffer it is locking / owns
    appByte,  \* application local: next byte to write
    writes,   \* number of releases so far (the app writes tag writes+1)
    isrPc,    \* ISR state: "idle" or "copy" (inside a bus read transaction)
    isrGot,   \* bytes the ISR has sent to the bridge in the current read
    released, \* ghost: id of the most recently released write
    isrSnap   \* ghost: value of `released` at the ISR's linearization point

vars == <<buf, front, isrIdx, appPc, w, appByte, writes, isrPc, isrGot,
          released, isrSnap>>

TypeOK ==
    /\ buf \in [Bufs -> [1..MsgLen -> Tags]]
    /\ front \in Bufs /\ isrIdx \in Bufs \cup {NONE}
    /\ appPc \in {"idle", "check", "write", "release"}
    /\ w \in Bufs /\ appByte \in 1..MsgLen + 1 /\ writes \in 0..MaxWrites
    /\ isrPc \in {"idle", "copy"} /\ isrGot \in Seq(Tags) /\ Len(isrGot) <= MsgLen
    /\ released \in Tags /\ isrSnap \in Tags

Init ==
    /\ buf = [i \in Bufs |-> [k \in 1..MsgLen |-> 0]]
    /\ front = 0 /\ isrIdx = NONE
    /\ appPc = "idle" /\ w = 0 /\ appByte = 1 /\ writes = 0
    /\ isrPc = "idle" /\ isrGot = <<>>
    /\ released = 0 /\ isrSnap = 0

(***************************************************************************)
(* URB_LockOutbox, step 1: w := 1 - front (front is the app's own variable). *)
(***************************************************************************)
AppLockPick ==
    /\ appPc = "idle" /\ writes < MaxWrites
    /\ w' = 1 - front
    /\ appPc' = "check"
    /\ UNCHANGED <<buf, front, isrIdx, appByte, writes, isrPc, isrGot,
                   released, isrSnap>>

(***************************************************************************)
(* URB_LockOutbox, step 2: load isr_idx.  If the ISR is still copying the  *)
(* buffer we want (it latched it before our previous release), the lock    *)
(* fails with URB_BUSY and the app retries later; it never waits.          *)
(***************************************************************************)
AppLockCheck ==
    /\ appPc = "check"
    /\ appPc' = IF isrIdx = w THEN "idle" ELSE "write"
    /\ appByte' = 1
    /\ UNCHANGED <<buf, front, isrIdx, w, writes, isrPc, isrGot, released,
                   isrSnap>>

(***************************************************************************)
(* The application stores one byte of its new message into buf[w].         *)
(* (Contract: a locked outbox is written completely before release.)       *)
(***************************************************************************)
AppWriteByte ==
    /\ appPc = "write" /\ appByte <= MsgLen
    /\ buf' = [buf EXCEPT ![w][appByte] = writes + 1]
    /\ appByte' = appByte + 1
    /\ appPc' = IF appByte = MsgLen THEN "release" ELSE "write"
    /\ UNCHANGED <<front, isrIdx, w, writes, isrPc, isrGot, released, isrSnap>>

(***************************************************************************)
(* URB_ReleaseOutbox: front := w, one single store.                        *)
(***************************************************************************)
AppRelease ==
    /\ appPc = "release"
    /\ front' = w
    /\ writes' = writes + 1 /\ released' = writes + 1
    /\ appPc' = "idle"
    /\ UNCHANGED <<buf, isrIdx, w, appByte, isrPc, isrGot, isrSnap>>

(***************************************************************************)
(* ISR, bridge starts reading this outbox: isr_idx := front (load front,   *)
(* store isr_idx; atomic because the ISR is not preempted).  This is the   *)
(* linearization point of the read.                                        *)
(***************************************************************************)
IsrReadBegin ==
    /\ isrPc = "idle"
    /\ isrIdx' = front
    /\ isrPc' = "copy" /\ isrGot' = <<>>
    /\ isrSnap' = released
    /\ UNCHANGED <<buf, front, appPc, w, appByte, writes, released>>

(***************************************************************************)
(* ISR, one I2C byte: send buf[isr_idx][k] to the bridge.                  *)
(***************************************************************************)
IsrReadByte ==
    /\ isrPc = "copy" /\ Len(isrGot) < MsgLen
    /\ isrGot' = Append(isrGot, buf[isrIdx][Len(isrGot) + 1])
    /\ UNCHANGED <<buf, front, isrIdx, appPc, w, appByte, writes, isrPc,
                   released, isrSnap>>

(***************************************************************************)
(* ISR, end of the bus transaction (complete, or cut short by a bus error  *)
(* or timeout at any byte): isr_idx := NONE.                               *)
(***************************************************************************)
IsrReadEnd ==
    /\ isrPc = "copy"
    /\ isrIdx' = NONE
    /\ isrPc' = "idle" /\ isrGot' = <<>>
    /\ UNCHANGED <<buf, front, appPc, w, appByte, writes, released, isrSnap>>

AppNext == AppLockPick \/ AppLockCheck \/ AppWriteByte \/ AppRelease
IsrNext == IsrReadBegin \/ IsrReadByte \/ IsrReadEnd
Next == AppNext \/ IsrNext

(* The application keeps running (it retries a refused lock), and a bus    *)
(* read ends (complete, or cut short by a bus error or timeout).  Nothing  *)
(* obliges the bridge to read: IsrReadBegin has no fairness.               *)
Fairness == WF_vars(AppNext) /\ WF_vars(IsrReadEnd)

Spec == Init /\ [][Next]_vars /\ Fairness

-----------------------------------------------------------------------------
(* The application holds the lock on buf[w]. *)
AppHolds == appPc \in {"write", "release"}

(* Nobody else touches the buffer the application holds: the ISR does not  *)
(* read it and it is not the published buffer.                             *)
\* lobster-trace: urb.MBX_004
AppLockExclusive == AppHolds => (isrIdx # w /\ front # w)

(* The bytes the ISR has sent in one read all come from the same write.    *)
\* lobster-trace: urb.MBX_002
IsrReadNotTorn == \A i, j \in DOMAIN isrGot : isrGot[i] = isrGot[j]

(* ...and from the most recently released write at the read's start.       *)
\* lobster-trace: urb.MBX_003
IsrReadFresh == isrGot # <<>> => isrGot[1] = isrSnap

(* The interrupt never waits: in every state it can take its next step.    *)
\* lobster-trace: urb.MBX_001
IsrWaitFree == ENABLED IsrNext

(* The lock refuses (URB_BUSY) only when it must: the ISR is in a read of  *)
(* the very buffer the application wants (the counterpart of the bridge's *)
(* BusyOnlyWhenFull).  Stated on the step from the check back to idle,    *)
(* whatever action takes it, and against the ISR's real state (isrPc),    *)
(* not the index it publishes: an ISR that leaves isr_idx set after a     *)
(* read refuses the application for nothing.                              *)
\* lobster-trace: urb.MBX_004
LockBusyOnlyWhenReading ==
    [][appPc = "check" /\ appPc' = "idle" => isrPc = "copy" /\ isrIdx = w]_vars

(* Progress: an application that keeps trying publishes every write; a    *)
(* refused lock succeeds once the read that blocked it is over.           *)
\* lobster-trace: urb.MBX_003
WritesPublished == <>(writes = MaxWrites)

THEOREM Spec => [](TypeOK /\ AppLockExclusive /\ IsrReadNotTorn
                          /\ IsrReadFresh /\ IsrWaitFree)
THEOREM Spec => LockBusyOnlyWhenReading /\ WritesPublished

-----------------------------------------------------------------------------
(* Reachability witnesses (spec/tla/manifest.json lists them per model).   *)
(* The lock is refused; the ISR reads while the application writes the    *)
(* other buffer; a release lands during a read (which still sends the     *)
(* older message); a whole message is sent; every write is published.     *)
ReachLockRefused == appPc = "check" /\ isrIdx = w
ReachReadDuringWrite == AppHolds /\ isrPc = "copy"
ReachReleaseDuringRead == isrPc = "copy" /\ released > isrSnap
ReachWholeMessageSent == Len(isrGot) = MsgLen
ReachAllPublished == writes = MaxWrites
=============================================================================
