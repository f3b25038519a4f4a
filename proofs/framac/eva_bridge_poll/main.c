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
