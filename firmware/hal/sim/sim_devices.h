/*
 * sim_devices.h: simulated nodes and bridges as the world (sim/world/world.c) sees them: opaque
 * handles and accessors.
 *
 * Why opaque: the world drives devices through these calls and never depends on the layout of
 * the firmware's state (urb_node_t, urb_bridge_t), which the device ports own.
 */
#ifndef URBSIM_SIM_DEVICES_H
#define URBSIM_SIM_DEVICES_H

#include <stdbool.h>
#include <stdint.h>

#include "i2c.h"
#include "kernel.h"
#include "mcu.h"
#include "motor.h"
#include "sim_log.h"
#include "trace.h"
#include "uart.h"
#include "usb.h"

typedef struct sim_node sim_node_t;
typedef struct sim_bridge sim_bridge_t;

/* ---- nodes ---- */

/** Timing parameters of a simulated node (world.c fills them from the world's parameters). */
typedef struct {
    urbsim_clock_cfg_t clock;    /**< crystal, timer resolution, interrupt latency */
    uint16_t ticks_per_us;       /**< heartbeat timer rate (urb_node_config_t.ticks_per_us) */
    double i2c_isr_cycles;       /**< I2C slave handler length */
    double timer_isr_cycles;     /**< heartbeat handler length */
    double wake_cycles;          /**< main loop wake-up from sleep after an interrupt */
    double poll_cycles;          /**< one main-loop iteration without acquisition */
    double acq_ns;               /**< acquisition time of app_update */
    uint32_t acq_jitter_cycles;  /**< extra acquisition cycles, uniform 0..this */
    bool sync_capture;           /**< the port latches SYNC in hardware */
    /* urb_node_config_t fields the world sets */
    uint8_t address;
    uint16_t heartbeat_us;
    bool sync_enabled;
    uint16_t lead_us;
    uint8_t kd_q8;
    uint8_t kn_q8;
    uint16_t outlier_ns;
    uint8_t max_outliers;
    uint8_t acq_window;
    uint8_t acq_guard_us;
} sim_node_cfg_t;

/** Applications a simulated node can run. */
enum { SIM_APP_PROBE = 0, SIM_APP_MOTOR = 1, SIM_APP_BATTERY = 2, SIM_APP_IMU = 3, SIM_APP_IR = 4 };

/** Application parameters (probe: class, fingerprint, mailbox sizes; others: index). */
typedef struct {
    int app;
    uint8_t index;
    uint8_t class_id;
    uint32_t fingerprint;
    uint8_t out_size, in_size;
    bool fill_counter;            /**< probe: every byte carries the update counter (traces) */
    urbsim_motor_params_t motor;  /**< motor driver: the motor and leg it drives */
} sim_app_cfg_t;

/** Mark kinds in node logs (values of urb_node_mark_t, then the port's own). */
enum { SIM_MARK_BEAT = 0, SIM_MARK_ACQ_END = 1, SIM_MARK_SYNC = 2, SIM_MARK_READ = 3, SIM_MARK_BOOT = 4,
       SIM_MARK_DRIVE = 5 /**< motor driver applied a voltage: value = mV + 0x8000, | SIM_DRIVE_FRESH */ };

/** In a DRIVE mark: the update took a command that arrived since the previous one (a command
 *  overwritten in the inbox before an update took it never shows). */
#define SIM_DRIVE_FRESH 0x10000u

/** A new unpowered node attached to `bus`; NULL when the application is unknown or memory is out. */
sim_node_t *sim_node_new(const char *name, urbsim_kernel_t *k, urbsim_trace_t *tr, urbsim_i2c_bus_t *bus,
                         const sim_node_cfg_t *cfg, const sim_app_cfg_t *app, const urbsim_rng_t *rng);
void sim_node_free(sim_node_t *n);
/** Power on at now: clock restarts, urb_node_init runs (bootup, init). */
void sim_node_power_on(sim_node_t *n);
/** Power loss at now: the node drops off the bus at once; nothing it had pending happens. */
void sim_node_power_off(sim_node_t *n);
sim_log_t *sim_node_log(sim_node_t *n);
/** out[0..8]: sync state, period_q8, phase_q8, lead_ticks, acq_ticks, syncs, rejected, synced, init result. */
void sim_node_status(const sim_node_t *n, int64_t *out);
/** Named counters (ppm, polls, updates, boots, irqs, isr_ns, marks_lost); NaN when unknown. */
double sim_node_stat(const sim_node_t *n, const char *name);
/** Motor driver nodes: true state of the motor and leg now: out[0..5] = motor angle (rad), speed
 *  (rad/s), current (A), applied average voltage (V), leg angle (rad), case temperature (degC).
 *  -1 for other nodes. */
int sim_node_plant(sim_node_t *n, double *out);

/* ---- bridges ---- */

enum { SIM_UPLINK_RS232 = 0, SIM_UPLINK_USB = 1 };

typedef struct {
    urbsim_clock_cfg_t clock;
    double i2c_isr_cycles;     /**< I2C master handler */
    double uart_isr_cycles;    /**< UART RX / TXE handler */
    double timer_isr_cycles;   /**< heartbeat handler */
    double usb_isr_cycles;     /**< USB handlers */
    double wake_cycles;        /**< main loop wake-up after an interrupt, before poll runs */
    double poll_cycles;        /**< one main-loop iteration */
    urbsim_ns_t busy_poll_ns;  /**< poll period while not idle */
    double uart_divider_hz;    /**< baud generator clock (0 = exact baud) */
    double i2c_bitrate;
    /* urb_bridge_config_t fields the world sets */
    uint8_t fifo_depth;
    uint32_t baud;
    uint16_t heartbeat_us;
    bool scan_at_start;
    bool usb_read_always;      /**< host driver mode, usb.h */
    bool heartbeat_sof;        /**< USB bridges: derive the heartbeat tick from SOF (1 ms) */
} sim_bridge_cfg_t;

/** Host side of the uplink: bytes from the bridge (RS232) or an IN transfer (USB) reached the
 *  host's driver at t. */
typedef void (*sim_bridge_host_fn)(void *hctx, int bridge, const uint8_t *data, uint32_t n, urbsim_ns_t t);

/** Bridge mark kinds (urb_mark_t + 8); value = level. */
enum { SIM_BMARK_SERVE = 8, SIM_BMARK_SYNC = 9, SIM_BMARK_EMIT = 10 };

/** A new unpowered bridge with its I2C bus; USB bridges attach to the shared host bus. */
sim_bridge_t *sim_bridge_new(const char *name, int id, int uplink, urbsim_kernel_t *k, urbsim_trace_t *tr,
                             const sim_bridge_cfg_t *cfg, urbsim_usb_bus_t *usb_bus, sim_bridge_host_fn host,
                             void *hctx, const urbsim_rng_t *rng);
void sim_bridge_free(sim_bridge_t *b);
void sim_bridge_power_on(sim_bridge_t *b);
void sim_bridge_power_off(sim_bridge_t *b);
/** Host side: bytes the host's UART sends to an RS232 bridge. */
uint32_t sim_bridge_host_send(sim_bridge_t *b, const uint8_t *data, uint32_t n);
int sim_bridge_uplink(const sim_bridge_t *b);
int sim_bridge_usb_index(const sim_bridge_t *b);
const char *sim_bridge_name(const sim_bridge_t *b);
urbsim_i2c_bus_t *sim_bridge_bus(sim_bridge_t *b);
/** The RS232 line in direction dir (0 host->bridge, 1 bridge->host), NULL for USB bridges. */
urbsim_uart_line_t *sim_bridge_uart(sim_bridge_t *b, int dir);
sim_log_t *sim_bridge_log(sim_bridge_t *b);
/** Named counters (see world.c); NaN when unknown. */
double sim_bridge_stat(const sim_bridge_t *b, const char *name);

#endif /* URBSIM_SIM_DEVICES_H */
