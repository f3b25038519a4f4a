/*
 * The same host application and the same node application, unchanged, on I2C, CAN and RS485
 * (issue #39): the host side is one sequence of downlink transactions through urb_downlink_t (what
 * the bridge firmware issues for the host library's requests), the node side the node library with
 * one application that only uses urb_node.h (firmware/apps/echo, which urb-node-hosted runs too). Every topology must give the same mailbox results:
 * statuses, the nodes' echoes, the identification, the heartbeat lock from SYNC and the fault flag
 * cleared by a complete identification read.
 *
 * Witnesses that the checks are reached: every node ran app_update and echoed, every identification
 * decoded, the PLL tracked SYNC on every downlink. Seeded bugs (tests/firmware/node_dl/run_mutants.sh):
 * URB_MUTANT_NODE_DL_FRONT_BUFFER, URB_MUTANT_NODE_DL_NO_SYNC, URB_MUTANT_NODE_DL_NO_ID_DONE
 * (firmware/node/urb_node_dl.c) each make this program fail.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include <cmocka.h>

#include "topology.h"
#include "urb_core.h"

#define OPS 24u
#define ABSENT (TOPO_FIRST_ADDRESS + 5u)

/* What the host application saw: one status per transaction, the data it read, and the decoded
 * identifications. */
typedef struct {
    int status[OPS];
    uint8_t data[OPS][32];
    uint8_t n;
    urb_identification_t ident[TOPO_NODES];
    bool fault_before[TOPO_NODES], fault_after[TOPO_NODES];
    uint8_t sync_state[TOPO_NODES];
    uint32_t echoes[TOPO_NODES];
} host_result_t;

static topo_t topo;
static host_result_t results[3];

static int op(host_result_t *r, uint8_t dl_op, uint8_t address, uint8_t mailbox, uint8_t length, uint8_t counter,
              const uint8_t *src)
{
    uint8_t *buf = r->data[r->n];
    if (src != NULL) {
        memcpy(buf, src, length);
    }
    int const s = topo_txn(&topo, dl_op, address, mailbox, length, counter, buf);
    r->status[r->n] = s;
    r->n++;
    return s;
}

static bool read_ident(host_result_t *r, uint8_t i, urb_identification_t *id)
{
    uint8_t const at = r->n;
    if (op(r, URB_DL_READ, (uint8_t)(TOPO_FIRST_ADDRESS + i), 0u, 25u, 0u, NULL) != URB_STATUS_OK) {
        return false;
    }
    return urb_identification_decode(id, r->data[at], 25u) == 25;
}

/* The host application: the same calls whatever the downlink. */
static void host_app(host_result_t *r)
{
    memset(r, 0, sizeof *r);
    topo_run(&topo, 3000u);
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        (void)op(r, URB_DL_PROBE, (uint8_t)(TOPO_FIRST_ADDRESS + i), 0u, 0u, 0u, NULL);
    }
    (void)op(r, URB_DL_PROBE, ABSENT, 0u, 0u, 0u, NULL);
    /* SYNC once per heartbeat: the nodes' PLLs follow it */
    for (uint8_t c = 1u; c <= 20u; c++) {
        (void)topo_txn(&topo, URB_DL_SYNC, 0u, 0u, 0u, c, NULL);
        topo_run(&topo, 1000u - (topo.now % 1000u));
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        urb_node_sync_status_t st;
        urb_node_sync_status(&topo.nodes[i].node, &st);
        r->sync_state[i] = (uint8_t)st.state;
        assert_true(read_ident(r, i, &r->ident[i]));
    }
    /* writes, the applications' echoes, reads */
    static const uint8_t msg[TOPO_NODES][8] = {{1, 2, 3, 4, 5, 6, 7, 8}, {0xF0, 0xE1, 0xD2, 0xC3, 0xB4, 0xA5, 0x96, 0x87}};
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        (void)op(r, URB_DL_WRITE, (uint8_t)(TOPO_FIRST_ADDRESS + i), 1u, 8u, 0u, msg[i]);
    }
    topo_run(&topo, 5000u);
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        (void)op(r, URB_DL_READ, (uint8_t)(TOPO_FIRST_ADDRESS + i), 1u, 8u, 0u, NULL);
    }
    /* refusals: no such outbox, no such inbox, absent node */
    (void)op(r, URB_DL_READ, TOPO_FIRST_ADDRESS, 5u, 8u, 0u, NULL);
    (void)op(r, URB_DL_WRITE, TOPO_FIRST_ADDRESS, 6u, 8u, 0u, msg[0]);
    (void)op(r, URB_DL_READ, ABSENT, 1u, 8u, 0u, NULL);
    (void)op(r, URB_DL_WRITE, ABSENT, 1u, 8u, 0u, msg[0]);
    /* no SYNC for 20 heartbeats: LOST_SYNC sets Identification.fault; a complete identification
     * read begun after the fault clears it for the next one */
    topo_run(&topo, 20000u);
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        urb_identification_t id;
        assert_true(read_ident(r, i, &id));
        r->fault_before[i] = id.fault;
        /* a publication while that read ran (the acquisition time moved: timing differs per bus)
         * asks for one more read begun after it; three reach the cleared flag on every bus */
        for (uint8_t k = 0u; k < 3u; k++) {
            topo_run(&topo, 2000u);
            assert_true(read_ident(r, i, &id));
        }
        r->fault_after[i] = id.fault;
        r->echoes[i] = topo.nodes[i].app.echoes;
    }
    topo_run(&topo, 2000u);
}

static void run_on(topo_kind_t kind)
{
    assert_true(topo_init(&topo, kind));
    host_app(&results[kind]);
}

static void test_i2c(void **state)
{
    (void)state;
    run_on(TOPO_I2C);
}
static void test_can(void **state)
{
    (void)state;
    run_on(TOPO_CAN);
}
static void test_rs485(void **state)
{
    (void)state;
    run_on(TOPO_RS485);
}

/* What every downlink must give: the statuses the bridge reports on I2C, and the applications' work. */
static void check_host_result(const host_result_t *r)
{
    static const int expected[] = {
        URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_NO_NODE,                      /* probes */
        URB_STATUS_OK, URB_STATUS_OK,                                          /* identifications */
        URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK,            /* writes, reads */
        URB_STATUS_BAD_REQUEST, URB_STATUS_BAD_REQUEST, URB_STATUS_NO_NODE, URB_STATUS_NO_NODE,
        URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK,            /* identifications */
        URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK, URB_STATUS_OK};
    assert_int_equal(r->n, sizeof expected / sizeof expected[0]);
    for (uint8_t k = 0u; k < r->n; k++) {
        assert_int_equal(r->status[k], expected[k]);
    }
    for (uint8_t i = 0u; i < TOPO_NODES; i++) {
        assert_int_equal(r->ident[i].class_id, 0x42u);
        assert_int_equal(r->ident[i].index, i);
        assert_int_equal(r->ident[i].fingerprint, 0x00C0FFEEu);
        assert_int_equal(r->ident[i].inbox_sizes[1], 8u);
        assert_true(r->sync_state[i] >= (uint8_t)URB_NODE_SYNC_TRACK); /* SYNC reached the PLL */
        assert_true(r->fault_before[i]);
        assert_false(r->fault_after[i]);
        assert_true(r->echoes[i] > 0u); /* witness: the application ran */
        /* the echo of node i: what was written */
        const uint8_t *got = r->data[7u + i];
        assert_memory_equal(got, r->data[5u + i], 8u);
    }
}

static void test_same_results(void **state)
{
    (void)state;
    for (int k = 0; k < 3; k++) {
        check_host_result(&results[k]);
    }
    for (int k = 1; k < 3; k++) {
        assert_memory_equal(results[k].status, results[0].status, sizeof results[0].status);
        for (uint8_t n = 0u; n < results[0].n; n++) {
            /* reads of identification carry the acquisition time, which follows each bus's timing */
            bool const ident = (results[0].status[n] == URB_STATUS_OK) && (n == 3u || n == 4u || n >= 13u) /* identifications */;
            if (!ident) {
                assert_memory_equal(results[k].data[n], results[0].data[n], 8u);
            }
        }
        assert_memory_equal(results[k].sync_state, results[0].sync_state, sizeof results[0].sync_state);
        assert_memory_equal(results[k].fault_after, results[0].fault_after, sizeof results[0].fault_after);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_i2c),
        cmocka_unit_test(test_can),
        cmocka_unit_test(test_rs485),
        cmocka_unit_test(test_same_results),
    };
    return cmocka_run_group_tests_name("three_downlinks", tests, NULL, NULL);
}
