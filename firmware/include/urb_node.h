/*
 * URB node library: the firmware side of one URB node (paper Sec. IV-A/IV-B, V-D, V-E).
 *
 * What it does
 *   - 8 inboxes + 8 outboxes, double-buffered, 1..32 bytes each, fixed at setup. Outbox 0
 *     (Identification) and inbox 0 (Command) belong to the library; 1..7 to the application.
 *   - The I2C slave downlink as a byte-event state machine (urb_node_i2c_event), O(1) per event.
 *   - The heartbeat: a timer locked to the bridge's SYNC broadcast by the paper's PLL (eq. 1, 2),
 *     with the phase lead set to the measured acquisition time, so that every node finishes
 *     acquiring right when the bridge starts reading.
 *   - The round-robin main loop (urb_node_poll): inbox 0 commands, the periodic app_update, app_idle.
 *
 * The mailbox algorithms are the TLA+ models spec/tla/MailboxOutbox.tla and MailboxInbox.tla,
 * implemented action by action (each C statement cites its action). Consequences for the caller:
 *   - urb_node_lock_outbox() fails with URB_NODE_ERR_BUSY only while the bridge is still reading the
 *     buffer the lock needs (it latched it before your previous release); retry later, never wait.
 *   - a locked outbox must be written COMPLETELY before urb_node_release_outbox() (the encoders do).
 *   - urb_node_lock_inbox() fails with URB_NODE_ERR_BUSY only when bridge writes keep landing
 *     during the lock (3 attempts); while you hold an inbox, at most one more bridge write to it is
 *     accepted, later ones are NACKed (the bridge answers NODE_BUSY) and reported as OVERRUN.
 *
 * Memory: all state is in the caller-owned urb_node_t (no globals, no heap), so one process can run
 * any number of nodes. Mailbox 1..7 buffers are carved at setup from one storage block the caller
 * passes to urb_node_init(): 2 x size bytes per mailbox, so RAM follows the real layout (a SensoRHex
 * motor node needs 46 bytes, not the 896 of a fixed 7 x 2 x 2 x 32 layout) and urb_node_t keeps
 * one size whatever the layout (no ABI-changing macros). Mailbox 0 buffers live inside urb_node_t.
 *
 * Concurrency contract: urb_node_timer_event and urb_node_i2c_event are the interrupt side; they
 * must not preempt each other (same priority). Every other function is the application side
 * (thread level, one caller at a time). Single-byte index variables are the only shared state
 * between the two sides, plus counters with a single writer each.
 *
 * Errors are small negative numbers (URB_NODE_ERR_*); no function ever waits.
 */
#ifndef URB_NODE_H
#define URB_NODE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "urb_i2c_event.h"
#include "urb_node_hal.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ===== Constants ========================================================================== */

#define URB_NODE_MAILBOXES 8u    /**< inboxes per node, and outboxes per node */
#define URB_NODE_MAX_SIZE 32u    /**< largest mailbox, bytes */
#define URB_NODE_OUTBOX0_SIZE 25u /**< outbox 0: Identification (urb_core.h URB_IDENTIFICATION_SIZE) */
#define URB_NODE_INBOX0_SIZE 6u  /**< inbox 0: Command (urb_core.h URB_COMMAND_SIZE) */
/** Storage block bytes for application mailboxes whose sizes add up to `total` (double-buffered). */
#define URB_NODE_STORAGE_BYTES(total) (2u * (total))

/* Results. Non-negative: success. */
#define URB_NODE_OK 0             /**< success */
#define URB_NODE_NEW 1            /**< urb_node_lock_inbox: a message no earlier lock returned */
#define URB_NODE_ERR_BUSY (-1)    /**< the mailbox algorithm refused the lock now: retry later */
#define URB_NODE_ERR_ARG (-2)     /**< NULL pointer, mailbox number or size out of range */
#define URB_NODE_ERR_SETUP (-3)   /**< mailbox not set up, or set up twice */
#define URB_NODE_ERR_STATE (-4)   /**< wrong moment: setup after start, release without lock, double lock */
#define URB_NODE_ERR_NOMEM (-5)   /**< the storage block passed to urb_node_init is too small */
#define URB_NODE_ERR_CONFIG (-6)  /**< invalid urb_node_config_t or HAL */

/* ===== I2C slave events (downlink, spec/schema/README.md) ================================= */

/* urb_i2c_event_t (URB_I2C_ADDR_WRITE .. URB_I2C_STUCK for a node) is in urb_i2c_event.h. */

#define URB_I2C_ACK 0x100u  /**< urb_node_i2c_event: acknowledge (receive and address events) */
#define URB_I2C_NACK 0x200u /**< urb_node_i2c_event: do not acknowledge */

/* ===== Faults and hooks =================================================================== */

/** Fault codes delivered to the fault hook (always from urb_node_poll, never from an interrupt). */
typedef enum {
    URB_NODE_FAULT_CHECKSUM = 1,  /**< a downlink write failed its check (nothing was stored) */
    URB_NODE_FAULT_OVERRUN = 2,   /**< a write was refused (both inbox buffers in use) or app_update missed a heartbeat */
    URB_NODE_FAULT_LOST_SYNC = 3, /**< no SYNC for lost_sync_beats heartbeats: free-running at the last period */
    URB_NODE_FAULT_STUCK_BUS = 4  /**< the port reported the bus held beyond its timeout */
} urb_node_fault_t;

#define URB_NODE_FAULT_CODES 4u /**< number of fault codes */

typedef struct urb_node urb_node_t;

/** The application (paper Fig. 4, right column). Any member may be NULL (the struct itself may not).
 *  `user` is the pointer given to urb_node_init. Hooks run at thread level, from urb_node_init or
 *  urb_node_poll. */
typedef struct urb_node_hooks {
    void (*bootup)(urb_node_t *node, void *user); /**< power-up: set class, index, fingerprint, mailboxes */
    void (*init)(urb_node_t *node, void *user);   /**< after the node is on the bus: initialise the application */
    void (*reset)(urb_node_t *node, void *user);  /**< inbox 0 RESET command */
    void (*idle)(urb_node_t *node, void *user);   /**< every main-loop iteration (keep it short: it delays app_update) */
    void (*update)(urb_node_t *node, void *user); /**< every update_divider heartbeats (1 kHz by default) */
    void (*signal)(urb_node_t *node, void *user, uint8_t signal);        /**< inbox 0 SIGNAL command */
    void (*fault)(urb_node_t *node, void *user, urb_node_fault_t fault); /**< a fault occurred */
} urb_node_hooks_t;

/* ===== Configuration ====================================================================== */

/** Node configuration, referenced by urb_node_init (it must outlive the node). Start from
 *  urb_node_config_default(). */
typedef struct urb_node_config {
    uint8_t i2c_address;     /**< 7-bit slave address, 1..127 (real buses: 0x08..0x77) */
    uint8_t fw_major;        /**< firmware version reported in Identification */
    uint8_t fw_minor;        /**< firmware version reported in Identification */
    uint8_t fw_patch;        /**< firmware version reported in Identification */
    uint16_t ticks_per_us;   /**< heartbeat timer rate, ticks per microsecond (1..1000); default 48 */
    uint16_t heartbeat_us;   /**< nominal heartbeat = SYNC period, us; default 1000 (1 kHz) */
    uint8_t update_divider;  /**< app_update every N heartbeats (1..255); default 1 */
    uint8_t sync_enabled;    /**< 1: lock the heartbeat to SYNC; 0: free-run at heartbeat_us */
    uint16_t lead_us;        /**< phase lead dt_adj; 0 = the measured acquisition time t_acq (default) */
    uint8_t kd_q8;           /**< K_d of eq. 1 in 1/256 (0..255; 0: the estimate stops after gear shifting); default 32 = 1/8 */
    uint8_t kn_q8;           /**< K_n of eq. 2 in 1/256 (0..255; 0: no phase feedback after acquisition); default 64 = 1/4 */
    uint16_t lock_ns;        /**< |phase error| counting toward lock; default 1000 ns */
    uint8_t lock_count;      /**< consecutive in-lock SYNCs before `synced` (0: the first one); default 4 */
    uint16_t outlier_ns;     /**< |phase error| or period deviation rejected while tracking; default 2000 ns */
    uint8_t max_outliers;    /**< consecutive outliers tolerated before re-acquiring; default 4 */
    uint8_t max_gap;         /**< largest SYNC counter gap still used to measure the period (0: none); default 8 */
    uint8_t lost_sync_beats; /**< heartbeats without SYNC before LOST_SYNC; default 10 */
    uint8_t acq_window;      /**< t_acq = largest sample of the last acq_window..2 x acq_window on-time
                                  updates (1..255; 0 acts as 1); default 16 */
    uint8_t acq_guard_us;    /**< added to every t_acq sample, so acquisition ends this long before the
                                  SYNC interrupt (which would lengthen it); default 1 us */
} urb_node_config_t;

/* ===== Node state (caller-owned; members are private: use the functions) ================== */

/** One outbox (MailboxOutbox.tla). Shared: front (application writes), isr_idx (interrupt writes). */
typedef struct {
    uint16_t offset;          /* first buffer at storage + offset, second at + size */
    uint8_t size;             /* bytes, 0 = not set up */
    volatile uint8_t front;   /* latest released buffer: written only by the application */
    volatile uint8_t isr_idx; /* buffer the interrupt is sending, NONE (2) when idle: interrupt only */
    uint8_t held;             /* application local: buffer w it holds, NONE when not locked */
} urb_node_outbox_t;

/** One inbox (MailboxInbox.tla). Shared: front, isr_idx (interrupt writes), app_idx (application). */
typedef struct {
    uint16_t offset;           /* as for outboxes */
    uint8_t size;              /* bytes, 0 = not set up */
    volatile uint8_t front;    /* latest committed buffer: written only by the interrupt */
    volatile uint8_t isr_idx;  /* buffer the interrupt is filling, NONE when idle: interrupt only */
    volatile uint8_t app_idx;  /* buffer the application claims/holds, NONE: application only */
    volatile uint8_t fresh[2]; /* fresh[b]: buffer b holds a commit no lock returned yet; written by
                                  whoever owns buffer b under the algorithm, like the data bytes */
} urb_node_inbox_t;

/** Downlink transaction state (interrupt side only). */
typedef struct {
    uint16_t crc;      /* running link_check over the covered bytes */
    uint8_t state;     /* URB_I2C_ST_* (urb_node.c) */
    uint8_t mailbox;   /* mailbox of the current transaction */
    uint8_t count;     /* bytes of the current transaction after the select byte */
    uint8_t check_ok;  /* all check bytes so far matched */
    uint8_t crc16;     /* the transaction's check is CRC-16 (covered length 1 + size > 14) */
    uint8_t selected;  /* outbox selected for reads (kept until the next select; 0 after reset) */
    uint8_t sync_ok;   /* SYNC: magic seen */
    uint32_t sync_t;   /* SYNC: tick captured at the general-call match */
} urb_node_i2c_t;

/** Heartbeat PLL (paper Sec. V-E). Written by the two interrupts; requests from the main loop. */
typedef struct {
    uint32_t period_q8;   /* That_d: period estimate, ticks * 256 (eq. 1) */
    uint32_t nominal_q8;  /* nominal period, ticks * 256 */
    uint32_t next_beat;   /* tick of the pending heartbeat compare */
    uint32_t last_beat;   /* tick of the latest heartbeat t_n */
    uint32_t prev_sync;   /* t_d of the previous SYNC */
    int32_t phase_q8;     /* latest phase error t_n - t_d + dt_adj, ticks * 256 */
    int32_t expect_q8;    /* phase error the last correction leaves: the next one should be near it */
    uint32_t fixed_lead;  /* dt_adj fixed by configuration, ticks; 0 = use the measured t_acq */
    uint32_t lead_prev;   /* dt_adj used at the previous SYNC (a lead change is not an outlier) */
    uint16_t lock_ticks;  /* lock_ns in ticks */
    uint16_t outlier_ticks; /* outlier_ns in ticks */
    uint16_t syncs;       /* SYNCs used (wraps) */
    uint16_t rejected;    /* SYNCs rejected as outliers or duplicates (wraps) */
    uint8_t next_frac;    /* fraction (1/256 tick) of the pending heartbeat's ideal time */
    uint8_t last_frac;    /* fraction of t_n */
    uint8_t state;        /* urb_node_sync_t */
    uint8_t gear;         /* period filter gear: K_d starts at 1 and halves per SYNC down to kd_q8 */
    uint8_t good;         /* consecutive in-lock SYNCs */
    uint8_t outliers;     /* consecutive rejected phase samples */
    uint8_t quiet;        /* heartbeats since the last SYNC */
    uint8_t prev_counter; /* counter of the previous SYNC */
    uint8_t have_prev;    /* prev_sync/prev_counter are valid */
    uint8_t req_ack;      /* last configuration request applied (interrupt writes) */
} urb_node_pll_t;

/** Sync states reported by urb_node_sync_status. */
typedef enum {
    URB_NODE_SYNC_OFF = 0,     /**< synchronisation disabled: free-running at the nominal period */
    URB_NODE_SYNC_FREE = 1,    /**< enabled, no SYNC yet or lost: free-running at the last period */
    URB_NODE_SYNC_TRACK = 2,   /**< following SYNC, not yet within lock_ns for lock_count SYNCs */
    URB_NODE_SYNC_LOCKED = 3   /**< locked: Identification.synced is set */
} urb_node_sync_t;

/** The node. Caller-owned, zero-initialised by urb_node_init; do not touch the members.
 *  Member order is for Cortex-M0+ code size: byte fields first (ldrb reaches offsets < 32), then
 *  halfwords and words (ldrh < 64, ldr < 128), the sub-structures (reached through a pointer) last. */
struct urb_node {
    uint8_t started;            /* on the bus: interrupt events are handled, setup is refused */
    uint8_t div;                /* timer interrupt: heartbeats since the last due update */
    volatile uint8_t update_due; /* timer interrupt: updates due (wraps) */
    uint8_t update_done;        /* main loop: updates run or skipped (wraps) */
    uint8_t flags;              /* main loop: URB_F_* (urb_node_internal.h) */
    volatile uint8_t req_seq;   /* main loop -> timer interrupt: configuration request number */
    uint8_t req_enable;         /* main loop -> timer interrupt: requested sync enable */
    volatile uint8_t id_reads;  /* interrupt: outbox-0 reads begun (wraps) */
    volatile uint8_t id_done;   /* interrupt: id_reads value of the last complete outbox-0 read */
    uint8_t id_fault_after;     /* main loop: fault flag may clear once a read begun after this completes
                                   (set at each publication and at each fault delivered) */
    int8_t setup_err;           /* first error of a setup call in bootup */
    uint8_t acq_count;          /* main loop: t_acq samples in the current window */
    uint8_t class_id;
    uint8_t index;
    volatile uint8_t isr_faults[URB_NODE_FAULT_CODES]; /* per code, written by the interrupts only */
    uint8_t seen_faults[URB_NODE_FAULT_CODES];         /* per code, main loop copy */
    uint16_t req_period_us;     /* main loop -> timer interrupt: requested nominal period (0: keep) */
    uint16_t req_lead_us;       /* main loop -> timer interrupt: requested fixed lead (0: measured) */
    uint16_t id_acq_us;         /* main loop: published Identification.acq_time */
    uint16_t storage_len;
    uint16_t storage_used;
    const urb_node_hal_t *hal;
    const urb_node_hooks_t *hooks;
    void *user;
    const urb_node_config_t *cfg; /* the caller's configuration (referenced, not copied) */
    uint8_t *storage;
    uint32_t fingerprint;
    volatile uint32_t update_beat; /* timer interrupt: heartbeat that made the latest update due */
    volatile uint32_t acq_ticks; /* main loop: t_acq + guard (windowed max), read by the SYNC interrupt */
    uint32_t acq_win;           /* main loop: largest t_acq + guard sample of the current window */
    urb_node_pll_t pll;
    urb_node_i2c_t i2c;
    urb_node_outbox_t outbox[URB_NODE_MAILBOXES];
    urb_node_inbox_t inbox[URB_NODE_MAILBOXES];
    uint8_t mb0[2u * URB_NODE_OUTBOX0_SIZE + 2u * URB_NODE_INBOX0_SIZE]; /* mailbox 0 buffers */
};

/* ===== Lifecycle ========================================================================== */

/** Fills *cfg with the defaults documented in urb_node_config_t (address 0: set i2c_address). */
void urb_node_config_default(urb_node_config_t *cfg);

/* hal, hooks, cfg and storage (mailboxes 1..7; NULL when storage_len is 0) are referenced, not
 * copied: they must outlive the node. On error the node stays off the bus. */
/** Initialises *node, runs hooks->bootup, goes on the bus (address, first heartbeat), runs hooks->init.
 *  Returns URB_NODE_OK, _ERR_ARG, _ERR_CONFIG or the first error a setup call in bootup returned. */
int urb_node_init(urb_node_t *node, const urb_node_hal_t *hal, const urb_node_hooks_t *hooks, void *user,
                  const urb_node_config_t *cfg, uint8_t *storage, uint16_t storage_len);

/** One main-loop iteration: an inbox-0 command, a due app_update, faults (each code at most once
 *  per poll: a refused write's OVERRUN and a missed heartbeat's are one delivery), outbox 0
 *  refresh, app_idle. Faults counted before a RESET command of the same poll reach the hook after
 *  the reset hook (and set Identification.fault again). Returns a mask of URB_NODE_POLL_* telling
 *  what ran. */
uint8_t urb_node_poll(urb_node_t *node);

/* Sleeping between polls makes app_update start a fixed time after the heartbeat (low acquisition
 * jitter). Check with interrupts masked (Cortex-M: cpsid i; check; wfi; cpsie i): no lost wake-up. */
/** True when urb_node_poll has work now (a due update, a fault, a new command); when false the
 *  main loop may sleep until the next interrupt. */
bool urb_node_has_work(const urb_node_t *node);

#define URB_NODE_POLL_COMMAND 0x01u /**< an inbox 0 command was executed */
#define URB_NODE_POLL_UPDATE 0x02u  /**< app_update ran */
#define URB_NODE_POLL_IDENT 0x04u   /**< outbox 0 was refreshed */
#define URB_NODE_POLL_FAULT 0x08u   /**< at least one fault was delivered */

/* ===== Interrupt entry points ============================================================= */

/** Heartbeat timer compare interrupt: the tick set by hal->set_compare was reached. O(1). */
void urb_node_timer_event(urb_node_t *node);

/** I2C slave interrupt, one call per bus event. Returns URB_I2C_ACK / URB_I2C_NACK, or for
 *  URB_I2C_TX_BYTE the byte to send (0..255). O(1): at most one CRC byte update. */
uint16_t urb_node_i2c_event(urb_node_t *node, urb_i2c_event_t event, uint8_t byte);

/* ===== Setup (only from hooks->bootup) ==================================================== */

/** Sets the 8-bit node class (Identification.class_id). */
int urb_node_set_class(urb_node_t *node, uint8_t class_id);

/** Sets the 6-bit node index (0..63) distinguishing nodes of one class. */
int urb_node_set_index(urb_node_t *node, uint8_t index);

/** Sets the layout fingerprint reported in Identification (URB_NODE_<NAME>_FINGERPRINT). */
int urb_node_set_fingerprint(urb_node_t *node, uint32_t fingerprint);

/** Sets up inbox n (1..7) with size bytes (1..32), zero-filled, from the storage block. */
int urb_node_setup_inbox(urb_node_t *node, uint8_t n, uint8_t size);

/** Sets up outbox n (1..7) with size bytes (1..32), zero-filled, from the storage block. */
int urb_node_setup_outbox(urb_node_t *node, uint8_t n, uint8_t size);

/* ===== Mailbox access (application side) ================================================== */

/** Locks inbox n (1..7) and points *data at the latest committed message (size bytes, read-only).
 *  Returns URB_NODE_NEW if no earlier lock returned it, URB_NODE_OK if one did, or _ERR_BUSY/_ARG/_SETUP/_STATE. */
int urb_node_lock_inbox(urb_node_t *node, uint8_t n, const uint8_t **data);

/** Releases inbox n; *data from the lock must not be used afterwards. */
int urb_node_release_inbox(urb_node_t *node, uint8_t n);

/** Locks outbox n (1..7) and points *data at a buffer to fill completely (size bytes).
 *  Returns URB_NODE_OK, or _ERR_BUSY (the bridge still reads the buffer: retry later), _ARG, _SETUP, _STATE. */
int urb_node_lock_outbox(urb_node_t *node, uint8_t n, uint8_t **data);

/** Publishes outbox n: the next bridge read returns it. Inside app_update the first release of the
 *  update also marks the end of data acquisition (unless urb_node_mark_acquired came first). */
int urb_node_release_outbox(urb_node_t *node, uint8_t n);

/** Marks the end of this update's data acquisition now. The phase lead is acq_guard_us plus t_acq,
 *  the largest mark - heartbeat of the last acq_window..2 x acq_window on-time updates. */
void urb_node_mark_acquired(urb_node_t *node);

/** Size of inbox n (0 when not set up or n out of range). */
uint8_t urb_node_inbox_size(const urb_node_t *node, uint8_t n);

/** Size of outbox n (0 when not set up or n out of range). */
uint8_t urb_node_outbox_size(const urb_node_t *node, uint8_t n);

/* ===== Heartbeat status =================================================================== */

/** Heartbeat synchronisation state, for telemetry, tests and the simulation. */
typedef struct {
    urb_node_sync_t state; /**< see urb_node_sync_t */
    uint32_t period_q8;    /**< That_d, ticks * 256 */
    int32_t phase_q8;      /**< latest phase error t_n - t_d + dt_adj, ticks * 256 */
    uint32_t lead_ticks;   /**< dt_adj in use */
    uint32_t acq_ticks;    /**< measured t_acq plus acq_guard_us (0 until measured): dt_adj unless fixed */
    uint32_t last_beat;    /**< tick of the latest heartbeat */
    uint16_t syncs;        /**< SYNCs used (wraps) */
    uint16_t rejected;     /**< SYNCs rejected (wraps) */
} urb_node_sync_status_t;

/** Copies the heartbeat state into *out (read from the main loop: values may be one SYNC apart). */
void urb_node_sync_status(const urb_node_t *node, urb_node_sync_status_t *out);

/** True when the heartbeat is locked to the downlink SYNC (Identification.synced). */
bool urb_node_synced(const urb_node_t *node);

/* ===== Observation (telemetry, tests, the simulation's trace observers) =================== */
/* Read-only views of state the interrupt side may change right after the call: call them from
 * the interrupt context itself, or treat the values as a snapshot. */

/** True when a heartbeat made app_update due and urb_node_poll has not run it yet. */
bool urb_node_update_due(const urb_node_t *node);

/** Downlink (I2C slave) transaction phase. */
typedef enum {
    URB_NODE_DL_IDLE = 0,        /**< no transaction: bytes are NACKed, reads return 0xFF */
    URB_NODE_DL_SELECT = 1,      /**< addressed for writing: the next byte is MailboxSelect */
    URB_NODE_DL_WRITE = 2,       /**< receiving the data of inbox `mailbox` */
    URB_NODE_DL_WRITE_CHECK = 3, /**< receiving the check of that write */
    URB_NODE_DL_WRITE_DONE = 4,  /**< size + check bytes received, check passed: commit at STOP or repeated START */
    URB_NODE_DL_SELECTED = 5,    /**< a read select was received: nothing more expected */
    URB_NODE_DL_READ = 6,        /**< sending outbox `mailbox` */
    URB_NODE_DL_SYNC = 7,        /**< general call: SYNC magic, then counter */
    URB_NODE_DL_IGNORE = 8       /**< refused or finished: NACK until STOP or START */
} urb_node_dl_phase_t;

/** The downlink transaction in progress (urb_node_downlink). */
typedef struct {
    urb_node_dl_phase_t phase; /**< see urb_node_dl_phase_t */
    uint8_t mailbox;           /**< inbox being written (WRITE..WRITE_DONE) or outbox being read (READ) */
    uint8_t count;             /**< bytes after the select byte (WRITE..), or in READ the index of the byte
                                    the next TX_BYTE sends (data 0..size-1, then the check) */
} urb_node_downlink_t;

/** Copies the downlink transaction state into *out. */
void urb_node_downlink(const urb_node_t *node, urb_node_downlink_t *out);

#define URB_NODE_NO_BUFFER 2u /**< urb_node_buffers_t: no buffer (the NONE of the TLA+ mailbox models) */

/** Buffer indices (0, 1 or URB_NODE_NO_BUFFER) of a double-buffered mailbox (MailboxInbox.tla). */
typedef struct {
    uint8_t front; /**< latest committed buffer */
    uint8_t isr;   /**< buffer the interrupt is filling */
    uint8_t app;   /**< buffer the application claims or holds */
} urb_node_buffers_t;

/** Copies the buffer indices of inbox n into *out; false (nothing copied) when n is out of range
 *  or the inbox is not set up. */
bool urb_node_inbox_buffers(const urb_node_t *node, uint8_t n, urb_node_buffers_t *out);

#ifdef __cplusplus
}
#endif

#endif /* URB_NODE_H */
