/*
 * Shared helpers of the host library's cmocka tests (tests/host_c/test_*.c): transfer pools that
 * check every request completes exactly once, response frames, and a link to the real bridge
 * firmware compiled for the host (firmware/hal/hosted rig) in virtual time.
 */
#ifndef HOST_TEST_H
#define HOST_TEST_H

#include <pthread.h>
#include <setjmp.h>
#include <stdbool.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>

#include <cmocka.h>

#include "bridge_hosted.h"
#include "urb_discovery.h"
#include "urb_host_core.h"
#include "urb_loop.h"

#define POOL 256u
#define MS URB_NS_PER_MS

/** Transfers of one test, and how often each came back. */
typedef struct {
    urb_transfer_t t[POOL];
    unsigned done[POOL];
    urb_transfer_t *order[POOL * 4u]; /**< completions in the order they came */
    size_t count;
} pool_t;

void pool_init(pool_t *p);
/** Takes every completion of `core`; fails the test when one is not from the pool or comes twice. */
size_t pool_take(pool_t *p, urb_core_t *core);
/** A completion callback (user: the pool) doing pool_take's checks for one transfer. */
void pool_record(urb_transfer_t *t, void *pool);
/** Fails unless every one of the first n transfers came back exactly once. */
void pool_all_once(const pool_t *p, size_t n);
/** The k-th completion taken so far. */
urb_transfer_t *pool_nth(const pool_t *p, size_t k);

/** A read of `length` bytes at address 8, outbox 1, submitted at `now`. */
urb_transfer_t *submit_read(pool_t *p, size_t i, urb_core_t *core, uint8_t length, urb_ns_t now);
/** The response frame to `t` with `status` (data: t->length bytes of `fill` for an OK read). */
size_t response(uint8_t *buf, const urb_transfer_t *t, uint8_t status, uint8_t fill);
/** Every RS232 frame the core sends now; returns how many. */
size_t send_all(urb_core_t *core, urb_ns_t now);

/** A bridge's firmware in virtual time, wired to a host core. */
typedef struct {
    urb_hosted_rig_t rig;
    urb_core_t core;
    bool usb;
    bool dead;       /**< The bridge went away: nothing reaches it, nothing comes back */
    uint64_t frames;
} rig_link_t;

/** A link over RS232 or USB to a bridge with no nodes yet (add them with rig_add, then settle). */
void rig_link_init(rig_link_t *l, bool usb, const urb_core_config_t *cfg);
/** Adds a fake node of the given SensoRHex class (or any class with its own sizes). */
urb_fake_node_t *rig_add(rig_link_t *l, uint8_t address, uint8_t class_id, uint8_t index);
/** The core's clock: the rig's virtual microseconds, in ns. */
urb_ns_t rig_now(const rig_link_t *l);
/** Runs the bridge and the host for `us` microseconds (frames out, responses in, polls,
 *  USB frames every ms), dispatching completions with urb_core_dispatch. */
void rig_run(rig_link_t *l, uint32_t us);

/** A bridge firmware served on a descriptor from a thread of its own, in real time (the far end of
 *  a pty's master side for RS232, or of a SOCK_SEQPACKET socket for USB). */
typedef struct {
    urb_hosted_rig_t rig;
    int fd;
    bool usb;
    volatile bool stop;
    pthread_t thread;
} bridge_thread_t;

/** Starts serving `fd` with a bridge holding a MotorDriver:0 at 0x20 and a MotorDriver:1 at 0x21. */
void bridge_thread_start(bridge_thread_t *b, int fd, bool usb);
/** Stops the thread (the descriptor stays open). */
void bridge_thread_stop(bridge_thread_t *b);

int run_core_tests(void);
int run_usb_tests(void);
int run_discovery_tests(void);
int run_port_tests(void);
int run_loop_wait_tests(void);

#endif /* HOST_TEST_H */
