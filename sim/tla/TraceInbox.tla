------------------------------ MODULE TraceInbox ------------------------------
(***************************************************************************)
(* Trace validation of a node's inbox against MailboxInbox.tla.            *)
(*                                                                         *)
(* The simulation logs, for inbox 1 of one probe node:                     *)
(*   [ev |-> "wbegin", buf |-> b]  the bridge's first data byte: the       *)
(*                                 interrupt fills buffer b: IsrWriteBegin  *)
(*   [ev |-> "wnack"]              IsrWriteBegin refused (NACK)             *)
(*   [ev |-> "wbyte", index |-> k] data byte k stored: IsrWriteByte         *)
(*   [ev |-> "commit"]             STOP after a good check: IsrWriteCommit  *)
(*   [ev |-> "abort"]              check failed / cut short: IsrWriteAbort  *)
(*   [ev |-> "lock", buf |-> b]    URB_LockInbox returned buffer b: the     *)
(*                                 AppLockCheckFront that succeeds          *)
(*   [ev |-> "busy"]               URB_LockInbox gave up: the last          *)
(*                                 AppLockUnclaim                           *)
(*   [ev |-> "rbyte", index |-> k, tag |-> w]  the application read byte k, *)
(*                                 last stored there by write w (0: the     *)
(*                                 zeroed setup): AppReadByte               *)
(*   [ev |-> "release"]            URB_ReleaseInbox: AppRelease             *)
(* Any other event (e.g. "lock_error": the lock misused) matches nothing.  *)
(* The steps inside URB_LockInbox before its result (AppLockLoadFront,      *)
(* AppLockClaim, AppLockCheckIsr, a failed AppLockCheckFront and the        *)
(* retries' AppLockUnclaim) are not logged: TLC places them wherever the    *)
(* trace allows, while events remain. Accepted when a state matches every *)
(* event (urb_sim/tracebatch.py prints every state's l - 1, the number of  *)
(* events it matched). Every invariant of MailboxInbox.tla is checked on    *)
(* the way; a rejected trace says how far it matched.                      *)
(***************************************************************************)
EXTENDS MailboxInbox

CONSTANT Trace     \* the logged events (from sim/urb_sim/tracecheck.py)

VARIABLE l

tvars == <<vars, l>>

TraceInit == Init /\ l = 1

Is(name) == l <= Len(Trace) /\ Trace[l].ev = name

MatchWriteBegin ==
    /\ Is("wbegin")
    /\ IsrWriteBegin /\ isrPc' = "fill" /\ isrIdx' = Trace[l].buf
    /\ l' = l + 1

MatchWriteNack ==
    /\ Is("wnack")
    /\ IsrWriteBegin /\ isrPc' = "idle"
    /\ l' = l + 1

MatchWriteByte ==
    /\ Is("wbyte")
    /\ isrByte = Trace[l].index + 1 /\ IsrWriteByte
    /\ l' = l + 1

MatchCommit ==
    /\ Is("commit")
    /\ IsrWriteCommit
    /\ l' = l + 1

MatchAbort ==
    /\ Is("abort")
    /\ IsrWriteAbort
    /\ l' = l + 1

MatchLock ==
    /\ Is("lock")
    /\ a = Trace[l].buf /\ AppLockCheckFront /\ appPc' = "read"
    /\ l' = l + 1

MatchBusy ==
    /\ Is("busy")
    /\ tries = MaxRetry /\ AppLockUnclaim
    /\ l' = l + 1

MatchReadByte ==
    /\ Is("rbyte")
    /\ Len(appGot) = Trace[l].index /\ AppReadByte
    /\ appGot'[Len(appGot')] = Trace[l].tag
    /\ l' = l + 1

MatchRelease ==
    /\ Is("release")
    /\ AppRelease
    /\ l' = l + 1

(* Unlogged steps of URB_LockInbox; a failed AppLockCheckFront and the     *)
(* retries' unclaims only (the lock that succeeds, or gives up, is logged). *)
Hidden ==
    /\ l <= Len(Trace)
    /\ \/ AppLockLoadFront \/ AppLockClaim \/ AppLockCheckIsr
       \/ (AppLockCheckFront /\ appPc' = "unclaim")
       \/ (tries < MaxRetry /\ AppLockUnclaim)
    /\ UNCHANGED l

TraceNext ==
    \/ MatchWriteBegin \/ MatchWriteNack \/ MatchWriteByte \/ MatchCommit \/ MatchAbort
    \/ MatchLock \/ MatchBusy \/ MatchReadByte \/ MatchRelease \/ Hidden

=============================================================================
