/* Eva entry: the bridge main-loop step (urb_bridge_poll) interleaved with every other bridge entry
 * point: the UART receive and transmit interrupts, the heartbeat interrupt and the USB handlers,
 * under arbitrary bytes, times, transfers and downlink outcomes. */
#include "eva_bridge_env.h"

int eva_main(void)
{
    static uint8_t usb[URB_BRIDGE_USB_BUF + 1u];
    if (eva_bridge_start() != URB_OK) {
        return 1;
    }
    while (Frama_C_nondet(0, 1) != 0) {
        /* The scalar part of the FIFO invariant, which every handler keeps (ESBMC proves admit,
         * complete and emit keep it from any state within it, proofs/bmc/fw_bridge_fifo; WP proves
         * admit and complete keep urbb_fifo_ok, proofs/framac/fifo; urb_bridge_init establishes
         * it), restated for Eva: its interval domain cannot relate slot_count to the ring entries
         * that hold a slot, so emit's slot_count-- would seem to wrap from 0 to 255 and every
         * serving step after it would index the slots with an arbitrary byte. Likewise each USB
         * batch holds at most URB_BRIDGE_USB_BUF bytes: urbb_uplink_init and urb_bridge_usb_sof set
         * its length to the header's, and urbb_uplink_send appends a frame of len bytes only after
         * checking usb_len + len <= URB_BRIDGE_USB_BUF, a relation the intervals lose (they keep
         * usb_len <= 512 + 35). WP proves that bound an invariant of every writer
         * (proofs/framac/usb_batch, urbb_usb_ok), which Eva cannot use. These are the only
         * hypotheses (see eva_alarms.md). */
        /*@ admit eva_bridge.ring_head < URB_BRIDGE_RING_MAX && eva_bridge.ring_count <= URB_BRIDGE_RING_MAX &&
                  eva_bridge.slot_head < eva_bridge.cfg.fifo_depth &&
                  eva_bridge.slot_served <= eva_bridge.slot_count <= eva_bridge.cfg.fifo_depth &&
                  eva_bridge.usb_len[0] <= URB_BRIDGE_USB_BUF && eva_bridge.usb_len[1] <= URB_BRIDGE_USB_BUF; */
        switch (Frama_C_interval(0, 7)) {
        case 0:
            urb_bridge_uart_rx(&eva_bridge, Frama_C_unsigned_char_interval(0u, 255u),
                               Frama_C_unsigned_int_interval(0u, 0xFFFFFFFFu));
            break;
        case 1: {
            uint8_t byte;
            (void)urb_bridge_uart_tx_pop(&eva_bridge, &byte);
            break;
        }
        case 2:
            urb_bridge_heartbeat(&eva_bridge);
            break;
        case 3:
            urb_bridge_usb_sof(&eva_bridge);
            break;
        case 4: {
            size_t const len = Frama_C_unsigned_int_interval(0u, URB_BRIDGE_USB_BUF + 1u);
            Frama_C_make_unknown((char *)usb, sizeof usb);
            (void)urb_bridge_usb_out(&eva_bridge, usb, len);
            break;
        }
        case 5:
            (void)urb_bridge_usb_in(&eva_bridge, usb, Frama_C_unsigned_int_interval(0u, sizeof usb));
            break;
        default:
            urb_bridge_poll(&eva_bridge);
            break;
        }
    }
    return 0;
}
