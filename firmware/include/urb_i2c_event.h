/*
 * URB I2C events: the one type both sides of the I2C downlink receive from their port.
 *
 * A node's slave port reports bus events to urb_node_i2c_event() (urb_node.h); a bridge's master
 * port reports completed operations to urb_i2c_master_event() (urb_downlink.h). Both kinds live in
 * one enum with disjoint values, so a file may include urb_node.h and the bridge headers together
 * (the simulation, a board running a node and a bridge) and an event handed to the wrong side is
 * refused by that side's handler instead of being misread as one of its own.
 */
#ifndef URB_I2C_EVENT_H
#define URB_I2C_EVENT_H

#ifdef __cplusplus
extern "C" {
#endif

/** I2C events. Slave events (0..8): what a node's slave interrupt saw; a repeated START shows up
 *  as the next ADDR_* event. Master completions (16..20): the bridge's last operation finished. */
typedef enum {
    URB_I2C_ADDR_WRITE = 0,   /**< slave: (repeated) START + own address + W; return ACK or NACK */
    URB_I2C_ADDR_READ = 1,    /**< slave: (repeated) START + own address + R; return ACK (bytes follow via TX_BYTE) */
    URB_I2C_GENERAL_CALL = 2, /**< slave: START + general call 0x00 + W: a SYNC begins; time-stamped here */
    URB_I2C_RX_BYTE = 3,      /**< slave: a data byte arrived (argument `byte`); return ACK or NACK */
    URB_I2C_TX_BYTE = 4,      /**< slave: the master clocks a byte out of us; return it (0..255) */
    URB_I2C_TX_NACK = 5,      /**< slave: the master NACKed our last byte: end of the read */
    URB_I2C_STOP = 6,         /**< slave: STOP condition */
    URB_I2C_BUS_ERROR = 7,    /**< slave: misplaced START/STOP or other bus error: abort the transaction */
    URB_I2C_STUCK = 8,        /**< slave: the port saw the bus held beyond its timeout: abort, STUCK_BUS fault */
    URB_I2C_EV_START = 16,    /**< master: START or repeated START is on the bus */
    URB_I2C_EV_ACK = 17,      /**< master: the byte written was acknowledged */
    URB_I2C_EV_NACK = 18,     /**< master: the byte written was not acknowledged */
    URB_I2C_EV_BYTE = 19,     /**< master: a byte was read (it is the event's `byte` argument) */
    URB_I2C_EV_ERROR = 20     /**< master: arbitration lost or bus error: the controller gave up */
} urb_i2c_event_t;

#ifdef __cplusplus
}
#endif

#endif /* URB_I2C_EVENT_H */
