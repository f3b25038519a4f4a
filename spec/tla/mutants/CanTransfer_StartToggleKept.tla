-------------------- MODULE CanTransfer_StartToggleKept --------------------
(* MUTANT of CanTransfer: after a start frame the receiver expects the start's own toggle bit again instead of the flipped one: every multi-frame transfer's second frame is refused as a repeat, so no multi-frame transfer is ever delivered (every check on mixing, repeats, integrity and duplicates still holds: a receiver that refuses everything is safe). *)
(* Expected: DeliveredUnlessCut *)
EXTENDS MCCanTransfer

MutReceive(s, f) ==
    IF f.start /\ ~f.end /\ ~(rx[s].active /\ f.tid = rx[s].tid) /\ f.tid # last[s]
    THEN /\ rx' = [rx EXCEPT ![s] = [active |-> TRUE, tid |-> f.tid, tog |-> TRUE, buf |-> <<f>>]]
         /\ ev' = "accept"
         /\ UNCHANGED <<last, count, done, bad>>
    ELSE Receive(s, f)
MutSpec == Init /\ [][NextBy(MutReceive)]_vars
=============================================================================
