/* An RS485 transceiver on tools/rs485_hub.py: rs485_hub_client.h. */
#include "rs485_hub_client.h"

#include "hub_socket.h"

#include <errno.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

/* the hub's message flags (tools/rs485_hub.py) */
#define UP_HELLO 0x01u
#define UP_STATUS 0x02u
#define UP_DRIVE 0x04u
#define UP_WAKE 0x08u
#define DOWN_WELCOME 0x01u
#define DOWN_EVENT 0x02u
#define DOWN_RX 0x04u
#define DOWN_SLOT 0x08u

static void put_message(uint8_t m[URB_RS485_HUB_MESSAGE], uint8_t flags, uint8_t byte, uint16_t seq, uint32_t value)
{
    m[0] = flags;
    m[1] = byte;
    m[2] = (uint8_t)(seq & 0xFFu);
    m[3] = (uint8_t)(seq >> 8);
    for (unsigned k = 0u; k < 4u; k++) {
        m[4u + k] = (uint8_t)((value >> (8u * k)) & 0xFFu);
    }
}

static uint32_t get_value(const uint8_t m[URB_RS485_HUB_MESSAGE])
{
    return (uint32_t)m[4] | ((uint32_t)m[5] << 8) | ((uint32_t)m[6] << 16) | ((uint32_t)m[7] << 24);
}

static void hub_tx_start(void *ctx)
{
    ((urb_rs485_hub_client_t *)ctx)->driving = true; /* the first character goes with the next acknowledgement */
}

static void hub_tx_abort(void *ctx)
{
    ((urb_rs485_hub_client_t *)ctx)->driving = false; /* a character on the line still ends (the shift register) */
}

static void hub_wake_at(void *ctx, uint32_t at_us)
{
    urb_rs485_hub_client_t *c = (urb_rs485_hub_client_t *)ctx;
    c->wake_set = true;
    c->wake = at_us;
}

bool urb_rs485_hub_connect(urb_rs485_hub_client_t *c, const char *path, uint32_t baud)
{
    memset(c, 0, sizeof *c);
    c->fd = -1;
    int const fd = urb_hub_socket_connect(path);
    if (fd < 0) {
        return false;
    }
    uint8_t m[URB_RS485_HUB_MESSAGE];
    put_message(m, UP_HELLO, 0u, 0u, baud);
    int e = 0;
    if (send(fd, m, sizeof m, MSG_NOSIGNAL) != (ssize_t)sizeof m) {
        e = errno;
    } else {
        struct pollfd p = {fd, POLLIN, 0};
        ssize_t n = -1;
        if (poll(&p, 1u, 5000) == 1) {
            n = recv(fd, m, sizeof m, 0);
        }
        if (n == 0) {
            e = ECONNRESET; /* the hub refused this station (its stderr says why) */
        } else if ((n != (ssize_t)sizeof m) || (m[0] != DOWN_WELCOME)) {
            e = (n < 0) ? ETIMEDOUT : EPROTO;
        } else {
            c->now = get_value(m);
            c->seq = (uint16_t)((uint16_t)m[2] | (uint16_t)((uint16_t)m[3] << 8));
            c->owe_ack = true;
        }
    }
    if (e != 0) {
        close(fd);
        errno = e;
        return false;
    }
    c->fd = fd;
    c->hal.ctx = c;
    c->hal.tx_start = hub_tx_start;
    c->hal.tx_abort = hub_tx_abort;
    c->hal.wake_at = hub_wake_at;
    c->hal.lock = NULL; /* the owner's calls never interleave: one thread */
    return true;
}

const char *urb_rs485_hub_advice(int err)
{
    if (err == ECONNRESET) {
        return "the hub refused this station; its stderr says why, e.g. another baud rate than the line's";
    }
    if (err == ETIMEDOUT) {
        return "the hub did not welcome this station within 5 s: is it stopped or overloaded?";
    }
    return "start tools/rs485_hub.py --socket PATH first, and give every station that PATH";
}

/* The next character when one is due: tx_start came and nothing of ours is on the line (the
 * first character, or a transmit slot: the last one ended). */
static bool next_char(urb_rs485_hub_client_t *c, void *owner, const urb_rs485_hub_owner_t *ops, uint8_t *byte)
{
    if (c->in_flight || !c->driving) {
        return false;
    }
    if (!ops->tx_next(owner, byte)) {
        c->driving = false; /* the driver is released after the last stop bit */
        return false;
    }
    return true;
}

bool urb_rs485_hub_flush(urb_rs485_hub_client_t *c, void *owner, const urb_rs485_hub_owner_t *ops)
{
    uint8_t byte = 0u;
    bool const drive = next_char(c, owner, ops, &byte);
    bool has = c->wake_set;
    uint32_t at = c->wake;
    uint32_t t = 0u;
    if ((ops->timer != NULL) && ops->timer(owner, &t) && (!has || ((int32_t)(t - at) < 0))) {
        has = true;
        at = t;
    }
    if (!c->owe_ack && !drive && (has == c->told_wake) && (!has || (at == c->told_at))) {
        return true; /* nothing new for the hub */
    }
    uint8_t m[URB_RS485_HUB_MESSAGE];
    put_message(m, (uint8_t)(UP_STATUS | (drive ? UP_DRIVE : 0u) | (has ? UP_WAKE : 0u)), byte, c->seq, at);
    if (send(c->fd, m, sizeof m, MSG_NOSIGNAL) != (ssize_t)sizeof m) {
        return false;
    }
    c->owe_ack = false;
    c->told_wake = has;
    c->told_at = at;
    if (drive) {
        c->in_flight = true;
        c->sent++;
    }
    return true;
}

bool urb_rs485_hub_service(urb_rs485_hub_client_t *c, void *owner, const urb_rs485_hub_owner_t *ops)
{
    for (;;) {
        uint8_t m[2u * URB_RS485_HUB_MESSAGE];
        ssize_t const n = recv(c->fd, m, sizeof m, MSG_DONTWAIT);
        if (n == 0) {
            return false;
        }
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return (errno == EAGAIN) || (errno == EWOULDBLOCK);
        }
        if ((n != (ssize_t)URB_RS485_HUB_MESSAGE) || ((m[0] & DOWN_EVENT) == 0u)) {
            errno = EPROTO;
            return false;
        }
        uint32_t const t = get_value(m);
        c->now = t;
        c->seq = (uint16_t)((uint16_t)m[2] | (uint16_t)((uint16_t)m[3] << 8));
        c->owe_ack = true;
        if (c->wake_set && ((int32_t)(t - c->wake) >= 0)) {
            c->wake_set = false; /* due: the owner asks again if it still needs one */
        }
        if (c->told_wake && ((int32_t)(t - c->told_at) >= 0)) {
            c->told_wake = false; /* the hub forgets a wake-up it delivered */
        }
        if ((m[0] & DOWN_RX) != 0u) {
            c->received++;
            ops->rx(owner, m[1], t);
        }
        if ((m[0] & DOWN_SLOT) != 0u) {
            c->in_flight = false;
        }
        ops->tick(owner, t);
        if (!urb_rs485_hub_flush(c, owner, ops)) {
            return false;
        }
    }
}

void urb_rs485_hub_close(urb_rs485_hub_client_t *c)
{
    if (c->fd >= 0) {
        close(c->fd);
        c->fd = -1;
    }
}
