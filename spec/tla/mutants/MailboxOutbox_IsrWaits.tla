------------------------ MODULE MailboxOutbox_IsrWaits ------------------------
(* MUTANT of MailboxOutbox: a mutex instead of double buffering: the ISR   *)
(* may only start a read while the application holds no lock (it would    *)
(* stretch the I2C clock and wait).  Expected: IsrWaitFree.                *)
EXTENDS MailboxOutbox

MutReadBegin == ~AppHolds /\ IsrReadBegin

MutNext == AppNext \/ MutReadBegin \/ IsrReadByte \/ IsrReadEnd
MutSpec == Init /\ [][MutNext]_vars
MutIsrWaitFree == ENABLED (MutReadBegin \/ IsrReadByte \/ IsrReadEnd)
=============================================================================
