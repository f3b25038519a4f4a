----------------------------- MODULE MailboxInbox -----------------------------
(***************************************************************************)
(* One double-buffered INBOX of a URB node (paper Sec. IV-A, Fig. 2).       *)
(*                                                                         *)
(* Writer: the downlink interrupt (ISR) storing a bridge write.            *)
(* Reader: the node application (URB_LockInbox / URB_ReleaseInbox).        *)
(* The ISR is never preempted by the application; the application can be  *)
(* preempted by the ISR between any two of its steps; one bus write spans  *)
(* several ISR invocations (one per I2C byte) and the application runs     *)
(* between them.  A bus write ends with a valid checksum (commit), or is   *)
(* cut short / fails its checksum (abort: nothing is published).  Every    *)
(* step below is ONE memory access of the firmware; the firmware           *)
(* implements each action as written and cites its name.                   *)
(*                                                                         *)
(* Shared variables:                                                       *)
(*   front   : buffer holding the latest committed message (ISR writes).  *)
(*   isr_idx : buffer the ISR is filling, NONE when idle (ISR writes).     *)
(*   app_idx : buffer the application claims/owns, NONE if none (app).     *)
(*                                                                         *)
(* Change to the initial design, found by TLC (see README): after claiming *)
(* a buffer the application re-reads front (AppLockCheckFront).  Without   *)
(* it, an ISR write that began on the claimed buffer and was ABORTED       *)
(* between the app's load of front and its claim leaves a half-written     *)
(* buffer that the app then reads as a torn, never-committed message.      *)
(***************************************************************************)
EXTENDS Naturals, Sequences

CONSTANTS
    MsgLen,     \* bytes per message (>= 2 so that tearing is observable)
    MaxWrites,  \* number of bus write transactions explored (incl. NACKed)
    MaxRetry    \* lock attempts after the first before URB_BUSY

ASSUME MsgLen \in Nat \ {0, 1} /\ MaxWrites \in Nat \ {0} /\ MaxRetry \in Nat

NONE == 2           \* index value meaning "no buffer" (fits the C uint8_t)
Bufs == {0, 1}
Tags == 0..MaxWrites \* transaction ids; 0 = the value set up by URB_SetupInbox

VARIABLES
    buf,       \* buf[i][k]: transaction id of byte k of buffer i
    front,     \* shared: latest committed buffer (ISR writes, app reads)
    isrIdx,    \* shared: buffer the ISR is filling or NONE (ISR writes)
    appIdx,    \* shared: buffer claimed by the app or NONE (app writes)
    isrPc,     \* ISR state: "idle" or "fill" (inside a bus write)
    isrByte,   \* ISR local: next byte to store
    txs,       \* number of bus write transactions started (the tag of the next)
    appPc,     \* application program counter
    a,         \* application local: buffer being locked / read
    tries,     \* application local: failed lock attempts in this lock call
    appGot,    \* bytes the application has read from its locked buffer
    committed, \* ghost: tag of the most recently committed message
    aborted,   \* ghost: tags of aborted (corrupt / cut short) transactions
    appSnap,   \* ghost: `committed` at the application's linearization point
    callFails  \* ghost: failed attempts so far in the current URB_LockInbox call

vars == <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, appPc, a, tries,
          appGot, committed, aborted, appSnap, callFails>>

TypeOK ==
    /\ buf \in [Bufs -> [1..MsgLen -> Tags]]
    /\ front \in Bufs /\ isrIdx \in Bufs \cup {NONE} /\ appIdx \in Bufs \cup {NONE}
    /\ isrPc \in {"idle", "fill"} /\ isrByte \in 1..MsgLen + 1
    /\ txs \in 0..MaxWrites
    /\ appPc \in {"idle", "claim", "checkIsr", "checkFront", "unclaim", "read"}
    /\ a \in Bufs /\ tries \in 0..MaxRetry
    /\ appGot \in Seq(Tags) /\ Len(appGot) <= MsgLen
    /\ committed \in Tags /\ aborted \subseteq Tags /\ appSnap \in Tags
    /\ callFails \in 0..MaxRetry

Init ==
    /\ buf = [i \in Bufs |-> [k \in 1..MsgLen |-> 0]]
    /\ front = 0 /\ isrIdx = NONE /\ appIdx = NONE
    /\ isrPc = "idle" /\ isrByte = 1 /\ txs = 0
    /\ appPc = "idle" /\ a = 0 /\ tries = 0 /\ appGot = <<>>
    /\ committed = 0 /\ aborted = {} /\ appSnap = 0 /\ callFails = 0

(***************************************************************************)
(* ISR, bridge starts writing this inbox: t := 1 - front; if app_idx = t   *)
(* the write is NACKed (the bridge reports NODE_BUSY) and nothing changes; *)
(* else isr_idx := t.  Atomic: the ISR is not preempted.                   *)
(***************************************************************************)
IsrWriteBegin ==
    /\ isrPc = "idle" /\ txs < MaxWrites
    /\ txs' = txs + 1
    /\ IF appIdx = 1 - front
         THEN UNCHANGED <<isrIdx, isrPc, isrByte>>          \* NACK
         ELSE /\ isrIdx' = 1 - front
              /\ isrPc' = "fill" /\ isrByte' = 1
    /\ UNCHANGED <<buf, front, appIdx, appPc, a, tries, appGot, committed,
                   aborted, appSnap, callFails>>

(***************************************************************************)
(* ISR, one I2C byte: buf[isr_idx][k] := byte.                             *)
(***************************************************************************)
IsrWriteByte ==
    /\ isrPc = "fill" /\ isrByte <= MsgLen
    /\ buf' = [buf EXCEPT ![isrIdx][isrByte] = txs]
    /\ isrByte' = isrByte + 1
    /\ UNCHANGED <<front, isrIdx, appIdx, isrPc, txs, appPc, a, tries, appGot,
                   committed, aborted, appSnap, callFails>>

(***************************************************************************)
(* ISR, end of a complete transaction with a valid checksum:              *)
(* front := isr_idx; isr_idx := NONE (publish, in this order).             *)
(***************************************************************************)
IsrWriteCommit ==
    /\ isrPc = "fill" /\ isrByte = MsgLen + 1
    /\ front' = isrIdx /\ isrIdx' = NONE
    /\ isrPc' = "idle"
    /\ committed' = txs
    /\ UNCHANGED <<buf, appIdx, isrByte, txs, appPc, a, tries, appGot,
                   aborted, appSnap, callFails>>

(***************************************************************************)
(* ISR, transaction cut short (timeout, bus error) or checksum mismatch,  *)
(* after any number of bytes: isr_idx := NONE, nothing is published.       *)
(***************************************************************************)
IsrWriteAbort ==
    /\ isrPc = "fill"
    /\ isrIdx' = NONE /\ isrPc' = "idle"
    /\ aborted' = aborted \cup {txs}
    /\ UNCHANGED <<buf, front, appIdx, isrByte, txs, appPc, a, tries, appGot,
                   committed, appSnap, callFails>>

(***************************************************************************)
(* URB_LockInbox, step 1: a := front (load).                               *)
(***************************************************************************)
AppLockLoadFront ==
    /\ appPc = "idle"
    /\ a' = front
    /\ appPc' = "claim"
    /\ UNCHANGED <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, tries,
                   appGot, committed, aborted, appSnap, callFails>>

(***************************************************************************)
(* URB_LockInbox, step 2: app_idx := a (store).  From now on the ISR       *)
(* NACKs any write that would start on buffer a.                           *)
(***************************************************************************)
AppLockClaim ==
    /\ appPc = "claim"
    /\ appIdx' = a
    /\ appPc' = "checkIsr"
    /\ UNCHANGED <<buf, front, isrIdx, a, isrPc, isrByte, txs, tries, appGot,
                   committed, aborted, appSnap, callFails>>

(* A failed check sends the application to AppLockUnclaim.                  *)
LockFail == appPc' = "unclaim" /\ UNCHANGED <<appIdx, tries>>

(***************************************************************************)
(* URB_LockInbox, step 3: load isr_idx; if the ISR is filling buffer a     *)
(* (it began before our claim), fail this attempt.                         *)
(***************************************************************************)
AppLockCheckIsr ==
    /\ appPc = "checkIsr"
    /\ IF isrIdx = a
         THEN LockFail
         ELSE appPc' = "checkFront" /\ UNCHANGED <<appIdx, tries>>
    /\ UNCHANGED <<buf, front, isrIdx, a, isrPc, isrByte, txs, appGot,
                   committed, aborted, appSnap, callFails>>

(***************************************************************************)
(* URB_LockInbox, step 4 (added after TLC): load front again; if it is no  *)
(* longer a, a newer message was committed since step 1 and buffer a may   *)
(* hold an aborted half-write: fail this attempt.  Otherwise the app owns  *)
(* buf[a]; this load is the linearization point of the read.               *)
(***************************************************************************)
AppLockCheckFront ==
    /\ appPc = "checkFront"
    /\ IF front # a
         THEN LockFail /\ UNCHANGED <<appGot, appSnap, callFails>>
         ELSE /\ appPc' = "read" /\ appGot' = <<>> /\ tries' = 0
              /\ appSnap' = committed /\ callFails' = 0
              /\ UNCHANGED appIdx
    /\ UNCHANGED <<buf, front, isrIdx, a, isrPc, isrByte, txs, committed,
                   aborted>>

(***************************************************************************)
(* Failed attempt: app_idx := NONE (store), then retry from step 1, or     *)
(* give up with URB_BUSY after MaxRetry retries (the app never waits).     *)
(* The ghost callFails counts the failed attempts of this lock call on its *)
(* own (a call ends when it succeeds or its MaxRetry + 1st attempt fails), *)
(* so that LockFailsOnlyOnConflict does not rest on the counter it checks. *)
(***************************************************************************)
AppLockUnclaim ==
    /\ appPc = "unclaim"
    /\ appIdx' = NONE
    /\ appPc' = "idle"
    /\ tries' = IF tries < MaxRetry THEN tries + 1 ELSE 0   \* else: URB_BUSY
    /\ callFails' = IF callFails = MaxRetry THEN 0 ELSE callFails + 1
    /\ UNCHANGED <<buf, front, isrIdx, isrPc, isrByte, txs, a, appGot,
                   committed, aborted, appSnap>>

(***************************************************************************)
(* The application loads one byte of its locked buffer.                    *)
(***************************************************************************)
AppReadByte ==
    /\ appPc = "read" /\ Len(appGot) < MsgLen
    /\ appGot' = Append(appGot, buf[a][Len(appGot) + 1])
    /\ UNCHANGED <<buf, front, isrIdx, appIdx, isrPc, isrByte, txs, appPc, a,
                   tries, committed, aborted, appSnap, callFails>>

(***************************************************************************)
(* URB_ReleaseInbox: app_idx := NONE (possibly before reading all bytes).  *)
(***************************************************************************)
AppRelease ==
    /\ appPc = "read"
    /\ appIdx' = NONE
    /\ appPc' = "idle" /\ appGot' = <<>>
    /\ UNCHANGED <<buf, front, isrIdx, isrPc, isrByte, txs, a, tries,
                   committed, aborted, appSnap, callFails>>

IsrNext == IsrWriteBegin \/ IsrWriteByte \/ IsrWriteCommit \/ IsrWriteAbort
AppNext == AppLockLoadFront \/ AppLockClaim \/ AppLockCheckIsr
           \/ AppLockCheckFront \/ AppLockUnclaim \/ AppReadByte \/ AppRelease
Next == IsrNext \/ AppNext

(* Inside the library the application makes progress (a lock call, with  *)
(* its retries, returns), and it releases what it locked.  It starts a    *)
(* lock call when it wants (AppLockLoadFront is fair only for a retry)    *)
(* and reads as many bytes as it wants; the bridge writes when it wants.  *)
Fairness ==
    /\ WF_vars(tries > 0 /\ AppLockLoadFront)
    /\ WF_vars(AppLockClaim) /\ WF_vars(AppLockCheckIsr) /\ WF_vars(AppLockCheckFront)
    /\ WF_vars(AppLockUnclaim) /\ WF_vars(AppRelease)

Spec == Init /\ [][Next]_vars /\ Fairness

-----------------------------------------------------------------------------
AppHolds == appPc = "read"

(* The application never loses its lock: while it holds buf[a], app_idx    *)
(* still names a, the ISR is not filling a and a stays the published one's *)
(* twin only through a commit of the other buffer.                         *)
\* lobster-trace: urb.MBX_009
AppLockExclusive == AppHolds => (appIdx = a /\ isrIdx # a)

(* The bytes the application reads under one lock come from one write.   *)
\* lobster-trace: urb.MBX_006
AppReadNotTorn == \A i, j \in DOMAIN appGot : appGot[i] = appGot[j]

(* ...from the most recently committed write at the linearization point.  *)
\* lobster-trace: urb.MBX_007
AppReadFresh == appGot # <<>> => appGot[1] = appSnap

(* The application never sees bytes of an aborted (corrupt) transaction.  *)
\* lobster-trace: urb.MBX_008
NoAbortedDelivered == \A i \in DOMAIN appGot : appGot[i] \notin aborted

(* The interrupt never waits: it can always take its next step (a new     *)
(* transaction is NACKed at once rather than delayed).                    *)
\* lobster-trace: urb.MBX_005
IsrWaitFree == txs < MaxWrites \/ isrPc # "idle" => ENABLED IsrNext

(* The ISR refuses a write (NACK; the bridge answers NODE_BUSY) only when  *)
(* it must: the application has claimed the buffer the write would fill   *)
(* and not given it back (it is inside URB_LockInbox or holds the lock).  *)
(* Stated on the step, whatever action takes it (the counterpart of the   *)
(* bridge's BusyOnlyWhenFull).                                             *)
\* lobster-trace: urb.MBX_009
NackOnlyWhenClaimed ==
    [][isrPc = "idle" /\ txs' = txs + 1 /\ isrPc' = "idle"
         => appIdx = 1 - front /\ appPc \in {"checkIsr", "checkFront", "unclaim", "read"}]_vars

(* A lock attempt fails only when it must: the ISR is really filling the  *)
(* claimed buffer, or a newer message was committed since front was       *)
(* loaded; and a failed attempt ends the lock call (URB_BUSY: no retry is *)
(* owed, tries' = 0) exactly when it is the call's MaxRetry + 1st failed   *)
(* attempt, counted per call by the ghost callFails, not by tries: a      *)
(* count carried from an earlier call, or a step of 2, gives up early.    *)
\* lobster-trace: urb.MBX_010
LockFailsOnlyOnConflict ==
    [][/\ appPc = "checkIsr" /\ appPc' = "unclaim" => isrPc = "fill" /\ isrIdx = a
       /\ appPc = "checkFront" /\ appPc' = "unclaim" => front # a
       /\ appPc = "unclaim" /\ appPc' = "idle" => (tries' = 0 <=> callFails = MaxRetry)]_vars

(* Progress: every claim is given back (a lock call returns, a read ends  *)
(* in a release), so the ISR's NACKs stop.                                  *)
\* lobster-trace: urb.MBX_009
ClaimReturned == (appIdx # NONE) ~> (appIdx = NONE)

(* Progress: once the bridge has stopped writing, a lock call gets the     *)
(* message: its first attempt may have loaded front before the last       *)
(* commit, a retry loads it again and succeeds (with MaxRetry >= 1).       *)
\* lobster-trace: urb.MBX_010
LockSucceedsWhenQuiet ==
    (txs = MaxWrites /\ isrPc = "idle" /\ appPc = "claim" /\ tries = 0) ~> (appPc = "read")

THEOREM Spec => [](TypeOK /\ AppLockExclusive /\ AppReadNotTorn
                          /\ AppReadFresh /\ NoAbortedDelivered /\ IsrWaitFree)
THEOREM MaxRetry >= 1 => (Spec => NackOnlyWhenClaimed /\ LockFailsOnlyOnConflict /\ ClaimReturned
                                  /\ LockSucceedsWhenQuiet)

-----------------------------------------------------------------------------
(* Reachability witnesses (spec/tla/manifest.json lists them per model).   *)
(* A write is NACKed; one commits; one aborts leaving its bytes in a      *)
(* buffer; a lock attempt fails on each check; the lock gives up; the     *)
(* application reads a whole message, and reads while the ISR fills the   *)
(* other buffer.                                                           *)
ReachNack == isrPc = "idle" /\ txs < MaxWrites /\ appIdx = 1 - front
ReachCommit == committed > 0
ReachAbortLeftBytes == \E i \in Bufs : \E k \in 1..MsgLen : buf[i][k] \in aborted
ReachLockFailsOnIsr == appPc = "checkIsr" /\ isrIdx = a
ReachLockFailsOnFront == appPc = "checkFront" /\ front # a
ReachLockGivesUp == appPc = "unclaim" /\ tries = MaxRetry
(* A lock succeeds after a failed attempt: the next call counts from 0.   *)
ReachLockSucceedsOnRetry == appPc = "checkFront" /\ front = a /\ callFails > 0
ReachWholeMessageRead == Len(appGot) = MsgLen
ReachReadDuringWrite == AppHolds /\ isrPc = "fill"
ReachQuietLockCall == txs = MaxWrites /\ isrPc = "idle" /\ appPc = "claim" /\ tries = 0
=============================================================================
