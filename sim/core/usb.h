/*
 * usb.h: a full-speed USB host controller with 1-ms frames, its bulk schedule, and the URB kernel
 * driver of the paper's Fig. 9, shared by every bridge on one host port (hub).
 *
 * HOST CONTROLLER
 *   Frames start (SOF) every 1 ms of the controller's own clock (a crystal with its own error;
 *   its phase against the CPU's OS tick is drawn from the seed). At each SOF the controller takes
 *   the URBs submitted BEFORE that SOF, in submission order, and runs their transactions back to
 *   back after the SOF packet; a transaction that would not end before the end-of-frame guard
 *   waits for the next frame ("schedules it for transmission at the next USB cycle"). An OUT
 *   transfer runs when all of it fits. An IN token is sent only when a transaction with a full data
 *   packet (min(requested, max_packet) bytes) fits, as a host controller budgets it before it knows
 *   the answer's length; an IN answer longer than one packet sends the packets that fit and the
 *   rest at the start of the next frame (its completion comes with the last packet).
 *   Wire time of a bulk transaction of n data bytes at `bitrate` (12 Mb/s):
 *       token 35 + gap 8 + data (35 + 8n + stuffed bits) + gap 8 + handshake 19 + gap 8 bits,
 *   a transfer is split in packets of `max_packet` (64) bytes with a zero-length packet after an
 *   exact multiple; stuffed bits are counted in the data field (a 0 after six 1s, LSB first; not
 *   in the PID, the CRC16 or the tokens: at most a few bits per packet). An IN with
 *   no data is NAKed (70 bits) and retried in the next frame; so is an OUT the device cannot take
 *   yet (its buffer still holds the previous transfer: the token and first data packet, then NAK).
 *   SOF packet: 35 bits (SYNC 8, PID 8, frame number 11, CRC5 5, EOP 3), like a token; the
 *   frame's first token follows after an inter-packet gap of 8 bit times, as within a transaction.
 *   A device sees SOF (at the end of the SOF packet), OUT data, IN tokens and the acknowledgement
 *   of its IN data at their bus instants, each called at that instant (its HAL adds interrupt
 *   latency); at an IN token it answers from its endpoint buffer, as a device controller does.
 *
 * DRIVER (Fig. 9)
 *   write(data): the write thread hands one batch to the driver, which submits one OUT URB.
 *   The OUT completion interrupt (transaction end + hc_irq_ns) runs the write callback, which
 *   submits the IN URB for the responses ("auto read"): it is served in the next frame. The IN
 *   completion runs the read callback, which hands the data to user space (the read thread's
 *   wake-up latency is the host CPU model's business, see world.h).
 *   Alternative driver (read_always): one IN URB is always pending, resubmitted by each read
 *   callback, so the bridge's previous response buffer is fetched in every frame, busy or idle.
 */
#ifndef URBSIM_USB_H
#define URBSIM_USB_H

#include <stdbool.h>
#include <stdint.h>

#include "clock.h"
#include "kernel.h"
#include "trace.h"

#define URBSIM_USB_MAX_DEVS 8u
#define URBSIM_USB_MAX_XFER 512u
#define URBSIM_USB_MAX_URBS 64u
#define URBSIM_USB_MAX_DONE 16u

typedef struct {
    void *ctx;
    char name[32];
    bool attached;
    /* Device side, at bus instants. */
    void (*on_sof)(void *ctx, uint16_t frame, urbsim_ns_t t);
    void (*on_out)(void *ctx, const uint8_t *data, uint32_t len, urbsim_ns_t t);
    /** Fill buf (cap bytes) with the IN data; 0 = NAK. Called at the IN token: a device answers
     *  with what its endpoint buffer holds at that instant (its firmware cannot run in between). */
    uint32_t (*on_in)(void *ctx, uint8_t *buf, uint32_t cap, urbsim_ns_t t);
    /** Optional: the host acknowledged the IN data (the end of the transaction, of its last packet
     *  when it was split over frames): the endpoint buffer is free again. */
    void (*on_in_done)(void *ctx, urbsim_ns_t t);
    /** Optional, called at an OUT token: true while the endpoint buffer still holds the previous
     *  OUT transfer. The device NAKs (the host sent the token and the first data packet) and the
     *  host retries in the next frame. */
    bool (*out_busy)(void *ctx);
    /* Host side: the read callback delivers the IN data to user space. */
    void (*host_read)(void *hctx, const uint8_t *data, uint32_t len, urbsim_ns_t t);
    void *hctx;
    bool auto_read;        /**< the write callback submits the IN URB (Fig. 9) */
    bool read_always;      /**< the driver keeps one IN URB pending: each read callback resubmits
                                it (then auto_read is ignored) */
    uint32_t in_size;      /**< bytes the IN URB asks for */
    /* statistics */
    uint64_t outs, ins, naks, out_naks, deferred;
} urbsim_usb_dev_t;

typedef struct {
    uint8_t dev;
    bool in;
    uint16_t len;
    uint16_t got;            /**< IN split over frames: bytes the device handed (in data), 0 before */
    uint16_t sent;           /**< IN split over frames: bytes of them transferred so far */
    urbsim_ns_t submitted;
    uint8_t data[URBSIM_USB_MAX_XFER];
} urbsim_usb_urb_t;

typedef struct {
    urbsim_kernel_t *k;
    urbsim_trace_t *tr;
    char name[32];
    urbsim_clock_t *clock;   /**< the host controller's crystal (frame timing) */
    double bitrate;          /**< 12e6 */
    uint32_t max_packet;     /**< 64 */
    urbsim_ns_t phase_ns;    /**< local time of SOF 0 */
    urbsim_ns_t hc_irq_ns;   /**< completion interrupt latency of the host controller + driver */
    urbsim_ns_t eof_guard_ns;
    bool nak_next_frame;     /**< a NAKed transaction waits for the next frame; false (default): it
                                  is retried in its frame after the frame's other transactions */
    urbsim_usb_dev_t *devs[URBSIM_USB_MAX_DEVS];
    uint32_t n_devs;
    urbsim_usb_urb_t urbs[URBSIM_USB_MAX_URBS]; /**< FIFO ring, submission order */
    uint32_t urb_head, urb_len;
    uint64_t frame;          /**< number of the current frame */
    urbsim_ns_t sof_t;       /**< start of the current frame */
    urbsim_ns_t next_sof_t;
    uint32_t cursor_budget;  /**< URBs of the frame snapshot still to run */
    urbsim_usb_urb_t done[URBSIM_USB_MAX_DONE]; /**< completed transfers awaiting their callback */
    uint32_t done_head, done_len;
    uint32_t done_pending;   /**< of those, how many reached their bus end (interrupt raised) */
    bool running;
    uint64_t frames, busy_bits;
    uint8_t stuff[256][6][2];  /**< bit-stuffing table (stuffed bits, run of 1s after a byte) */
} urbsim_usb_bus_t;

/** Set up a bus; SOF events start at the first frame boundary (phase_ns of the clock). */
void urbsim_usb_init(urbsim_usb_bus_t *u, urbsim_kernel_t *k, urbsim_trace_t *tr, const char *name,
                     urbsim_clock_t *clock, urbsim_ns_t phase_ns);

/** Attach a device; returns its index, or -1 when the bus is full. */
int urbsim_usb_attach(urbsim_usb_bus_t *u, urbsim_usb_dev_t *d);

/** Start generating frames (idempotent). */
void urbsim_usb_run(urbsim_usb_bus_t *u);

/** Driver: submit one OUT transfer for device `dev` (the write thread's batch). False when the
 *  URB ring is full or the data is too long. */
bool urbsim_usb_write(urbsim_usb_bus_t *u, uint32_t dev, const uint8_t *data, uint32_t len);

/** Driver: submit one IN URB for device `dev` (also done by the write callback, see above). */
bool urbsim_usb_read(urbsim_usb_bus_t *u, uint32_t dev);

/** Bus bits of one bulk transfer of `len` bytes with this payload (NULL: no stuffing). */
uint32_t urbsim_usb_transfer_bits(const urbsim_usb_bus_t *u, const uint8_t *data, uint32_t len);

/** Nanoseconds of `bits` at the bus bit rate, rounded to nearest. */
urbsim_ns_t urbsim_usb_bits_ns(const urbsim_usb_bus_t *u, uint32_t bits);

/** Bits of the SOF packet: SYNC 8 + PID 8 + frame number 11 + CRC5 5 + EOP 3 (a token's 35). */
#define URBSIM_USB_SOF_BITS 35u
/** Bit times between two packets: the model's inter-packet gap (USB 2.0 7.1.18.1 lets a full-speed
 *  device take up to 6.5 to answer), after the SOF as between the packets of a transaction. */
#define URBSIM_USB_GAP_BITS 8u
#define URBSIM_USB_NAK_BITS 70u

#endif /* URBSIM_USB_H */
