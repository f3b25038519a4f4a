/* Size probe: the RAM of each downlink core's state on the target, read back with nm (make size-downlinks). */
#include "urb_can_master.h"
#include "urb_can_slave.h"
#include "urb_rs485_master.h"
#include "urb_rs485_slave.h"

char probe_can_slave[sizeof(urb_can_slave_t)];
char probe_can_master[sizeof(urb_can_master_t)];
char probe_rs485_slave[sizeof(urb_rs485_slave_t)];
char probe_rs485_master[sizeof(urb_rs485_master_t)];
