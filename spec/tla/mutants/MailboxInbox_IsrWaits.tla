------------------------- MODULE MailboxInbox_IsrWaits -------------------------
(* MUTANT of MailboxInbox: instead of NACKing, the ISR waits (clock        *)
(* stretching) until the application releases the buffer it needs.        *)
(* Expected: IsrWaitFree.                                                  *)
EXTENDS MailboxInbox

MutWriteBegin == appIdx # 1 - front /\ IsrWriteBegin

MutIsrNext == MutWriteBegin \/ IsrWriteByte \/ IsrWriteCommit \/ IsrWriteAbort
MutNext == MutIsrNext \/ AppNext
MutSpec == Init /\ [][MutNext]_vars
MutIsrWaitFree == txs < MaxWrites \/ isrPc # "idle" => ENABLED MutIsrNext
=============================================================================
