/*
 * fw_can_budgets.h: the CAN downlink state machines' call budgets (fw_can_master, fw_can_slave), on
 * top of fw_budgets.h's per-frame FW_CAN_FRAME_BUDGET.
 *
 * Kept apart from fw_budgets.h because every firmware proof reads that header: a line added there
 * changes the cache key of every fw_* run (proofs/bmc/cache/), and make check would re-run all of
 * them for real instead of replaying them.
 */
#ifndef FW_CAN_BUDGETS_H
#define FW_CAN_BUDGETS_H

#include "fw_budgets.h"

/* CAN master begin() and poll() (the bridge's main loop): begin() plans the request and queues as
 * many of its frames as the controller's transmit slots take, poll() one it refused; each within
 * the time of one shortest frame at 1 Mb/s (55 us = 2640 cycles), so the bus idles at most that
 * long between transactions on the CPU's account. */
#define FW_CAN_MASTER_CALL_BUDGET ((FW_CPU_HZ / FW_CAN_BIT_RATE) * FW_CAN_SHORTEST_FRAME_BITS)

#endif /* FW_CAN_BUDGETS_H */
