/*
 * Three in-memory topologies of one bridge-side downlink (urb_downlink_t) and two real nodes (the
 * node library and the echo application, firmware/apps/echo, the same on every downlink): I2C (the I2C master and
 * urb_node_i2c_event on a byte-level bus), CAN (the CAN master and urb_node_can_t on the
 * arbitrating bus of tests/firmware/can/can_bus.c) and RS485 (the RS485 master and urb_node_rs485_t
 * on a half-duplex line). Virtual time in microseconds, one node tick per microsecond; the node
 * timers, interrupts and main loops are run by topo_advance(). Deterministic.
 */
#ifndef URB_TOPOLOGY_H
#define URB_TOPOLOGY_H

#include <stdbool.h>
#include <stdint.h>

#include "can_bus.h"
#include "echo_app.h"
#include "urb_can_master.h"
#include "urb_downlink.h"
#include "urb_node.h"
#include "urb_node_can.h"
#include "urb_node_rs485.h"
#include "urb_rs485_master.h"

#define TOPO_NODES 2u
#define TOPO_FIRST_ADDRESS 0x20u /* nodes at 0x20, 0x21: valid on I2C, CAN (1..63) and RS485 */

typedef enum { TOPO_I2C = 0, TOPO_CAN = 1, TOPO_RS485 = 2 } topo_kind_t;

typedef struct topo topo_t;

/** One node: the library, its port and the application's state. */
typedef struct {
    topo_t *topo;
    urb_node_t node;
    urb_node_hal_t hal;
    urb_node_config_t cfg;
    echo_app_t app;          /* the node application (firmware/apps/echo) */
    uint8_t storage[64];
    uint32_t compare;
    bool compare_armed;
    uint8_t index;
    /* downlink ports */
    can_port_t can_port;
    urb_node_can_t can;
    urb_rs485_hal_t rs485_hal;
    urb_node_rs485_t rs485;
    bool rs485_driving;
} topo_node_t;

/** Faults to inject (topo_t.fault); a test sets them, clears them to end the fault. */
typedef struct {
    bool mute[TOPO_NODES];   /**< the node hears nothing (I2C: no address match; CAN, RS485: no reception) */
    uint8_t corrupt_rx;      /**< the n-th byte (I2C, RS485) or frame (CAN) a node sends the bridge from
                                  now on has a bit flipped (1: the next); 0: none */
    bool bus_fault;          /**< I2C: SDA held low; CAN: the bridge's controller is bus-off; RS485: a
                                  babbler holds the line */
    uint8_t collide;         /**< RS485: another driver garbles byte n (1-based) of the bridge's next
                                  frame to a node (SYNC broadcasts are left alone); 0: none */
} topo_fault_t;

struct topo {
    topo_kind_t kind;
    uint32_t now;
    urb_downlink_t dl;
    topo_node_t nodes[TOPO_NODES];
    topo_fault_t fault;
    uint32_t injected;       /* faults that took effect (witness) */
    /* I2C */
    urb_i2c_hal_t i2c_hal;
    urb_i2c_master_t i2c;
    int8_t i2c_target;       /* node index, -1 none, -2 general call */
    bool i2c_expect_address;
    bool i2c_pending;
    uint8_t i2c_ev, i2c_byte;
    uint32_t i2c_due;
    /* CAN */
    can_bus_t can_bus;
    can_port_t can_bport;
    urb_can_master_t can;
    /* RS485 */
    urb_rs485_hal_t rs485_hal;
    urb_rs485_master_t rs485;
    urb_rs485_timing_t rs485_tm;
    bool rs485_driving;
    bool rs485_pending;
    uint8_t rs485_byte;
    uint32_t rs485_busy_until;
    uint8_t rs485_m_pos, rs485_m_first; /* the bridge's frame being sent: bytes so far, its first */
    bool rs485_from_node;    /* the character on the line is (partly) a node's */
};

/** Builds topology `kind` with the two nodes on the bus (urb_node_init done); false on a set-up
 *  error. *t must stay where it is (the ports point into it). */
bool topo_init(topo_t *t, topo_kind_t kind);

/** Advances virtual time by at least one microsecond: bus events, node timers, node main loops. */
void topo_advance(topo_t *t);

/** Runs for `us` microseconds. */
void topo_run(topo_t *t, uint32_t us);

/** Runs one downlink transaction to its outcome (urb_status_t), or -100 when it never ends. */
int topo_txn(topo_t *t, uint8_t op, uint8_t address, uint8_t mailbox, uint8_t length, uint8_t counter, uint8_t *data);

#endif /* URB_TOPOLOGY_H */
