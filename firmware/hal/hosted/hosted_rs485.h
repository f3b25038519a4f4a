/*
 * The hosted bridge's RS485 downlink (urb-bridge-hosted --downlink rs485): the bridge core and the
 * RS485 master (firmware/downlink/rs485) as a station of tools/rs485_hub.py, with the nodes in
 * other processes (urb-node-hosted-rs485) on the same line. The master runs in the hub's line time
 * (its timeouts, silences and time stamps), the bridge core and its uplink in wall time.
 */
#ifndef URB_HOSTED_RS485_H
#define URB_HOSTED_RS485_H

#include <signal.h>
#include <stdbool.h>
#include <stdint.h>

#include "urb_bridge.h"

/** Runs the bridge with configuration *cfg, its RS232 uplink on the pty master `pty`, its
 *  downlink the RS485 line of the hub at `hub` at `baud`, until *stop is set or `seconds` pass
 *  (0: no limit). Returns the process exit code (1 when the hub cannot be reached or goes). */
int urb_hosted_rs485_run(const urb_bridge_config_t *cfg, int pty, const char *hub, uint32_t baud,
                         unsigned long seconds, volatile sig_atomic_t *stop, bool verbose);

#endif /* URB_HOSTED_RS485_H */
