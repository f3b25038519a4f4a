/* The mailbox table of sim_mailbox.h. */
#include "sim_mailbox.h"

#include <stddef.h>
#include <string.h>

static uint8_t mb_inbox_size(void *ctx, uint8_t m)
{
    return ((const sim_mailbox_t *)ctx)->in_size[m & 7u];
}

static uint8_t mb_outbox_size(void *ctx, uint8_t m)
{
    return ((const sim_mailbox_t *)ctx)->out_size[m & 7u];
}

static uint8_t *mb_write_begin(void *ctx, uint8_t m)
{
    return ((sim_mailbox_t *)ctx)->wbuf[m & 7u];
}

static void mb_write_commit(void *ctx, uint8_t m)
{
    sim_mailbox_t *t = (sim_mailbox_t *)ctx;
    memcpy(t->inbox[m & 7u], t->wbuf[m & 7u], SIM_MAILBOX_BYTES);
    t->writes[m & 7u]++;
}

static void mb_write_abort(void *ctx, uint8_t m)
{
    (void)ctx;
    (void)m;
}

static const uint8_t *mb_read_begin(void *ctx, uint8_t m)
{
    return ((const sim_mailbox_t *)ctx)->outbox[m & 7u];
}

static void mb_read_end(void *ctx, uint8_t m, bool complete)
{
    (void)ctx;
    (void)m;
    (void)complete;
}

static void mb_sync(void *ctx, uint32_t t, uint8_t counter)
{
    sim_mailbox_t *tab = (sim_mailbox_t *)ctx;
    (void)counter;
    tab->syncs++;
    tab->last_sync_t = t;
}

static void mb_fault(void *ctx, uint8_t code)
{
    (void)code;
    ((sim_mailbox_t *)ctx)->faults++;
}

void sim_mailbox_init(sim_mailbox_t *t, urb_dl_mailbox_t *mb)
{
    memset(t, 0, sizeof(*t));
    mb->ctx = t;
    mb->inbox_size = mb_inbox_size;
    mb->outbox_size = mb_outbox_size;
    mb->write_begin = mb_write_begin;
    mb->write_commit = mb_write_commit;
    mb->write_abort = mb_write_abort;
    mb->read_begin = mb_read_begin;
    mb->read_end = mb_read_end;
    mb->sync = mb_sync;
    mb->fault = mb_fault;
}

void sim_mailbox_set_inbox(sim_mailbox_t *t, uint8_t m, uint8_t size)
{
    t->in_size[m & 7u] = (size > SIM_MAILBOX_BYTES) ? (uint8_t)SIM_MAILBOX_BYTES : size;
}

void sim_mailbox_set_outbox(sim_mailbox_t *t, uint8_t m, const uint8_t *data, uint8_t size)
{
    size = (size > SIM_MAILBOX_BYTES) ? (uint8_t)SIM_MAILBOX_BYTES : size;
    t->out_size[m & 7u] = size;
    if ((data != NULL) && (size > 0u)) {
        memcpy(t->outbox[m & 7u], data, size);
    }
}
