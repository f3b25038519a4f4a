/*
 * bridge_hal_sim.h (private to bridge_hal_sim.c; the world uses sim_devices.h): one URB bridge (the real bridge firmware and its I2C master) on a simulated
 * microcontroller, driving a simulated I2C downlink and one uplink (RS232 line or USB device).
 *
 * What the port does, and when (virtual time):
 *   - now_us(): a 1 MHz counter of the bridge's crystal;
 *   - heartbeat_period(p): a periodic timer interrupt every p us of the bridge's clock calls
 *     urb_bridge_heartbeat (which makes the main loop send SYNC); with bridge.heartbeat_sof a USB
 *     bridge counts USB start-of-frame interrupts instead (1 ms each), so SYNC, and with it the
 *     nodes' acquisition, lines up with the frame in which the host's requests arrive;
 *   - RS232: every received byte raises the UART interrupt (urb_bridge_uart_rx with its time);
 *     uart_tx_kick starts transmission, each "transmit register empty" interrupt pops the next
 *     byte (urb_bridge_uart_tx_pop), so response bytes leave back to back;
 *   - USB, as the Cortex-M0+ port runs it (firmware/hal/cortex-m0plus/bridge_port.c: in the main
 *     loop): the USB controller's interrupt (bridge.usb_isr_cycles) at a SOF (the end of its
 *     packet), at the end of an OUT transfer and when the host acknowledged the IN data only notes
 *     the controller's flags and wakes the main loop. Each main-loop iteration then, in the port's
 *     order and before urb_bridge_poll: calls urb_bridge_usb_sof once if a SOF came since the last
 *     one, urb_bridge_usb_out with an OUT transfer received, and, when the IN buffer is free,
 *     urb_bridge_usb_in and arms what it returns. An IN token takes the armed buffer, or is NAKed
 *     when none is (the firmware cannot run between the token and the answer); an OUT token while
 *     the previous transfer has not been taken is NAKed. With bridge.heartbeat_sof the SOF
 *     interrupt also counts the heartbeat (a timer-like use of it, in its own handler);
 *   - I2C master: each operation goes to the bus model (i2c.h) when the firmware issues it; its
 *     completion raises the I2C interrupt, whose handler is urb_i2c_master_event;
 *   - main loop: urb_bridge_poll runs after every interrupt (after the wake-up and loop cost),
 *     and again every bridge.busy_poll_us while the bridge is not idle (timeouts), every
 *     clear_half_us while it bit-bangs a bus clear;
 *   - marks (SERVE, SYNC, EMIT edges) are logged with their virtual time.
 */
#ifndef URBSIM_BRIDGE_HAL_SIM_H
#define URBSIM_BRIDGE_HAL_SIM_H

#include <stdbool.h>
#include <stdint.h>

#include "sim_devices.h"
#include "urb_bridge.h"

/** A request seen entering the bridge (for the response lengths of the trace observer). */
typedef struct {
    uint8_t address, mailbox, length, seq;
    bool read;
} sim_pending_t;

#define SIM_PENDING_MAX 64u

/** The IN endpoint's buffer: free (the main loop may arm it), armed (the next IN token takes it),
 *  busy (being sent; free when the host acknowledges it). */
enum { SIM_USB_IN_FREE, SIM_USB_IN_ARMED, SIM_USB_IN_BUSY };

struct sim_bridge {
    char name[32];
    int id;
    int uplink;
    urbsim_kernel_t *k;
    urbsim_trace_t *tr;
    urbsim_mcu_t mcu;
    sim_bridge_cfg_t cfg;
    /* firmware */
    urb_bridge_t br;
    urb_bridge_config_t bcfg;
    urb_bridge_hal_t hal;
    urb_i2c_hal_t i2c_hal;
    urb_i2c_master_t master;
    urb_i2c_master_config_t mcfg;
    urb_downlink_t dl;
    /* buses */
    urbsim_i2c_bus_t bus;
    urbsim_uart_line_t to_bridge, to_host;  /* RS232 */
    urbsim_usb_dev_t usb;                   /* USB */
    urbsim_usb_bus_t *usb_bus;
    int usb_index;
    /* USB device controller: what its flags and endpoint buffers hold for the main loop */
    uint8_t usb_out[URBSIM_USB_MAX_XFER];
    uint32_t usb_out_len;
    bool usb_out_pending;        /**< an OUT transfer the main loop has not taken (OUT tokens NAKed) */
    bool usb_sof_flag;           /**< a SOF since the main loop last looked */
    int usb_in_state;            /**< SIM_USB_IN_*: the IN endpoint's buffer */
    uint8_t usb_in_buf[URB_BRIDGE_USB_BUF];
    uint32_t usb_in_len;
    uint64_t usb_in_closed_sof;  /**< usb_swap_sof of the armed batch */
    uint64_t usb_in_armed;       /**< batches armed */
    urbsim_ns_t usb_irq_at;      /**< start of the last USB interrupt handler reserved */
    /* USB delivery statistics: how many frames after the SOF that closed it a response batch went
     * out (0: in the frame that SOF began; the batch filled during frame n is due in frame n + 1) */
    uint64_t usb_sofs;           /**< SOFs the device saw since power-on */
    uint64_t usb_swap_sof;       /**< usb_sofs when the firmware last swapped its batches */
    uint64_t usb_resp_sent, usb_resp_late, usb_batches_late, usb_frames_late_max;
    /* port state */
    bool powered;
    uint64_t gen;
    uint32_t hb_period_us;
    uint64_t hb_gen;
    urbsim_handle_t hb_ev;       /**< the pending heartbeat event, withdrawn when replaced */
    uint64_t i2c_gen;            /**< bumped by abort/release: stale completions are dropped */
    double hb_next_local;
    uint32_t hb_sof_us;          /**< SOF heartbeat: microseconds counted toward the period */
    bool tx_active;
    bool poll_pending;
    urbsim_ns_t poll_at;
    uint64_t poll_gen;
    urbsim_handle_t poll_ev;     /**< the pending main-loop event, withdrawn when superseded */
    sim_bridge_host_fn host;
    void *hctx;
    sim_log_t log;
    /* Trace observer (category "bridge"): request frames handed to the firmware and response
     * frames it sends, reassembled from the uplink bytes, for TLA+ trace validation. */
    uint8_t obs_req[40];
    uint8_t obs_req_len;
    urbsim_ns_t obs_req_last;
    uint8_t obs_resp[40];
    uint8_t obs_resp_len;
    sim_pending_t obs_pend[SIM_PENDING_MAX];
    uint32_t obs_head, obs_len;
    uint64_t polls, boots;
    int init_result;
};

#endif /* URBSIM_BRIDGE_HAL_SIM_H */
