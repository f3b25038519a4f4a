/*
 * Shared fixture for the node library's cmocka tests: a node on the hosted HAL with recording
 * hooks, and a tiny I2C master that drives urb_node_i2c_event() byte by byte the way the bridge
 * does (spec/schema/README.md, "Frames"). Test code, so globals are fine here.
 */
#ifndef NODE_FIXTURE_H
#define NODE_FIXTURE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_hal_hosted.h"
#include "urb_node.h"
#include "urb_node_internal.h"
#include "sensorhex_motor.h"

#define FX_STORAGE 512u

typedef struct fixture fixture_t;

struct fixture {
    urb_node_t node;
    urb_hal_hosted_t port;
    urb_node_config_t cfg;
    urb_node_hooks_t hooks;
    uint8_t storage[FX_STORAGE];
    /* what bootup sets up */
    uint8_t in_sizes[URB_NODE_MAILBOXES];
    uint8_t out_sizes[URB_NODE_MAILBOXES];
    uint8_t class_id;
    uint8_t index;
    uint32_t fingerprint;
    int bootup_rc; /* first error a setup call returned in bootup */
    /* hook records */
    unsigned bootups, inits, resets, idles, updates, signals;
    uint8_t last_signal;
    unsigned faults[URB_NODE_FAULT_CODES + 1u];
    urb_node_fault_t last_fault;
    /* optional per-test behaviour */
    void (*on_update)(fixture_t *fx);
    void (*on_bootup)(fixture_t *fx);
    uint32_t update_work; /* ticks app_update "spends" before releasing outbox 1 (now_offset) */
};

/* Defaults: address 0x21, inbox 1 (2 B), inbox 2 (20 B, CRC-16 tier), outbox 1 (6 B), outbox 2 (20 B). */
void fx_defaults(fixture_t *fx);
/* urb_node_init with the fixture's HAL, hooks and storage. */
int fx_start(fixture_t *fx);

/* The I2C master. Each helper stops at the first NACK, like the bridge, then sends STOP. */
#define FX_ALL_ACKED (-1)
/* Sends addr+W and `n` bytes; returns the index of the first NACKed byte (0 = first byte after the
 * address), or FX_ALL_ACKED. `end`: URB_I2C_STOP, or URB_I2C_ADDR_* for a repeated start (not sent). */
int fx_write_raw(urb_node_t *node, const uint8_t *bytes, size_t n, bool stop);
/* Builds a DownlinkWrite frame for inbox m into out (select, data, check); returns its length.
 * corrupt != 0 flips that bit pattern into the last check byte. */
size_t fx_frame(uint8_t *out, uint8_t m, const uint8_t *data, size_t len, uint8_t corrupt);
/* Writes inbox m with a valid frame; returns like fx_write_raw. */
int fx_write(urb_node_t *node, uint8_t m, const uint8_t *data, size_t len);
/* Selects outbox m for reads; true if ACKed. */
bool fx_select(urb_node_t *node, uint8_t m);
/* Reads n bytes (data + check) from the selected outbox into out. */
void fx_read(urb_node_t *node, uint8_t *out, size_t n);
/* Reads outbox m (select + read of size + check bytes); true if the check over (m|0x80, data) holds. */
bool fx_read_checked(urb_node_t *node, uint8_t m, uint8_t size, uint8_t *data);
/* Sends a SYNC broadcast (general call, 0xA5, counter). */
void fx_sync(urb_node_t *node, uint8_t counter);
/* Writes a Command to inbox 0. */
int fx_command(urb_node_t *node, uint8_t opcode, uint8_t arg, uint16_t period_us, uint16_t lead_us);

/* A motor for the SensoRHex motor app: the sensor values it returns, and the drives it was given. */
typedef struct {
    uint16_t encoder;
    int16_t current, voltage, temp;
    bool hall;
    int16_t drive;     /* the last drive, mV */
    unsigned drives;   /* drives given */
} fake_motor_t;

uint16_t fake_motor_encoder(void *c);
int16_t fake_motor_current(void *c);
int16_t fake_motor_voltage(void *c);
int16_t fake_motor_temp(void *c);
bool fake_motor_hall(void *c);
void fake_motor_drive(void *c, int16_t mv);
/* The motor app's I/O on the fake_motor_t at `fm` (a constant initializer). */
#define FAKE_MOTOR_IO(fm) \
    {(fm), fake_motor_encoder, fake_motor_current, fake_motor_voltage, fake_motor_temp, fake_motor_hall, fake_motor_drive}

/* Step hook (urb_node_test_step): tests that preempt the application set this. */
extern void (*fx_step_hook)(urb_node_t *node, uint8_t step, void *ctx);
extern void *fx_step_ctx;

#endif /* NODE_FIXTURE_H */
