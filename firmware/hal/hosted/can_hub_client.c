/* A CAN controller on tools/can_hub.py: can_hub_client.h. */
#include "can_hub_client.h"

#include "hub_socket.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

static bool hub_tx(void *ctx, const urb_can_frame_t *f)
{
    urb_can_hub_client_t *c = (urb_can_hub_client_t *)ctx;
    uint8_t rec[URB_CAN_HUB_RECORD];
    memset(rec, 0, sizeof rec);
    rec[0] = (uint8_t)(f->id & 0xFFu);
    rec[1] = (uint8_t)(f->id >> 8);
    rec[4] = (f->len > URB_CAN_MTU) ? (uint8_t)URB_CAN_MTU : f->len;
    memcpy(&rec[5], f->data, rec[4]);
    if (send(c->fd, rec, sizeof rec, MSG_DONTWAIT) != (ssize_t)sizeof rec) {
        return false; /* the socket is full: the core tries again after the next frame-sent report */
    }
    c->unreported++;
    c->sent++;
    return true;
}

static void hub_tx_abort(void *ctx)
{
    (void)ctx; /* a frame the hub took is on the bus: nothing is queued here */
}

static uint8_t hub_state(void *ctx)
{
    (void)ctx;
    return (uint8_t)URB_CAN_ERROR_ACTIVE;
}

static void hub_recover(void *ctx)
{
    (void)ctx; /* never bus-off */
}

bool urb_can_hub_connect(urb_can_hub_client_t *c, const char *path)
{
    memset(c, 0, sizeof *c);
    c->fd = urb_hub_socket_connect(path);
    if (c->fd < 0) {
        return false;
    }
    c->hal.ctx = c;
    c->hal.tx = hub_tx;
    c->hal.tx_abort = hub_tx_abort;
    c->hal.state = hub_state;
    c->hal.recover = hub_recover;
    c->hal.lock = NULL;
    return true;
}

bool urb_can_hub_poll(urb_can_hub_client_t *c, void *owner, void (*on_rx)(void *owner, const urb_can_frame_t *f),
                      void (*on_tx_done)(void *owner))
{
    while (c->unreported > 0u) {
        c->unreported--;
        on_tx_done(owner);
    }
    for (;;) {
        uint8_t rec[64];
        ssize_t const n = recv(c->fd, rec, sizeof rec, MSG_DONTWAIT);
        if (n == 0) {
            return false;
        }
        if (n < 0) {
            return (errno == EAGAIN) || (errno == EWOULDBLOCK) || (errno == EINTR);
        }
        uint32_t const word = (uint32_t)rec[0] | ((uint32_t)rec[1] << 8) | ((uint32_t)rec[2] << 16) | ((uint32_t)rec[3] << 24);
        if ((n != (ssize_t)URB_CAN_HUB_RECORD) || (rec[4] > URB_CAN_MTU) || (word > 0x7FFu)) {
            c->dropped_records++; /* not a standard-identifier frame of the hub's format: not URB's */
            continue;
        }
        urb_can_frame_t f;
        f.id = (uint16_t)word;
        f.len = rec[4];
        memcpy(f.data, &rec[5], URB_CAN_MTU);
        c->received++;
        on_rx(owner, &f);
    }
}

void urb_can_hub_close(urb_can_hub_client_t *c)
{
    if (c->fd >= 0) {
        close(c->fd);
        c->fd = -1;
    }
}
