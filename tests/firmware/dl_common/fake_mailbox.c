/* Fake node mailboxes for the downlink slaves (fake_mailbox.h). */
#include "fake_mailbox.h"

#include <string.h>

static fake_mailbox_t *fm_of(void *ctx)
{
    return (fake_mailbox_t *)ctx;
}

static uint8_t inbox_size(void *ctx, uint8_t m)
{
    return (m < 8u) ? fm_of(ctx)->in_size[m] : 0u;
}

static uint8_t outbox_size(void *ctx, uint8_t m)
{
    return (m < 8u) ? fm_of(ctx)->out_size[m] : 0u;
}

static uint8_t *write_begin(void *ctx, uint8_t m)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if ((m >= 8u) || (fm->in_size[m] == 0u) || fm->writing[m]) {
        fm->rule_violations++;
        return NULL;
    }
    if (fm->app_holds[m]) {
        fm->refusals[m]++;
        return NULL;
    }
    fm->writing[m] = true;
    memset(fm->filling[m], 0xEE, sizeof fm->filling[m]);
    return fm->filling[m];
}

static void write_commit(void *ctx, uint8_t m)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if ((m >= 8u) || !fm->writing[m]) {
        fm->rule_violations++;
        return;
    }
    fm->writing[m] = false;
    memcpy(fm->inbox[m], fm->filling[m], fm->in_size[m]);
    fm->commits[m]++;
}

static void write_abort(void *ctx, uint8_t m)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if ((m >= 8u) || !fm->writing[m]) {
        fm->rule_violations++;
        return;
    }
    fm->writing[m] = false;
    fm->aborts[m]++;
}

static const uint8_t *read_begin(void *ctx, uint8_t m)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if ((m >= 8u) || (fm->out_size[m] == 0u) || fm->latched[m]) {
        fm->rule_violations++;
        return fm->outbox[m & 7u];
    }
    fm->latched[m] = true;
    fm->reads_begun[m]++;
    return fm->outbox[m];
}

static void read_end(void *ctx, uint8_t m, bool complete)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if ((m >= 8u) || !fm->latched[m]) {
        fm->rule_violations++;
        return;
    }
    fm->latched[m] = false;
    if (complete) {
        fm->reads_complete[m]++;
    } else {
        fm->reads_cut[m]++;
    }
}

static void sync(void *ctx, uint32_t t, uint8_t counter)
{
    fake_mailbox_t *fm = fm_of(ctx);
    fm->syncs++;
    fm->sync_t = t;
    fm->sync_counter = counter;
}

static void fault(void *ctx, uint8_t code)
{
    fake_mailbox_t *fm = fm_of(ctx);
    if (code < 5u) {
        fm->faults[code]++;
    } else {
        fm->rule_violations++;
    }
}

void fake_mailbox_init(fake_mailbox_t *fm, const uint8_t in_size[8], const uint8_t out_size[8])
{
    memset(fm, 0, sizeof *fm);
    fm->ops.ctx = fm;
    fm->ops.inbox_size = inbox_size;
    fm->ops.outbox_size = outbox_size;
    fm->ops.write_begin = write_begin;
    fm->ops.write_commit = write_commit;
    fm->ops.write_abort = write_abort;
    fm->ops.read_begin = read_begin;
    fm->ops.read_end = read_end;
    fm->ops.sync = sync;
    fm->ops.fault = fault;
    for (uint8_t m = 0u; m < 8u; m++) {
        fm->in_size[m] = in_size[m];
        fm->out_size[m] = out_size[m];
        for (uint8_t k = 0u; k < 32u; k++) {
            fm->outbox[m][k] = (uint8_t)(m * 40u + k + 1u);
        }
    }
}

uint32_t fake_mailbox_commits(const fake_mailbox_t *fm)
{
    uint32_t n = 0u;
    for (uint8_t m = 0u; m < 8u; m++) {
        n += fm->commits[m];
    }
    return n;
}

urb_dl_mailbox_t fake_mailbox_ops_without(const fake_mailbox_t *fm, int k)
{
    urb_dl_mailbox_t ops = fm->ops;
    switch (k) {
    case 0: ops.inbox_size = NULL; break;
    case 1: ops.outbox_size = NULL; break;
    case 2: ops.write_begin = NULL; break;
    case 3: ops.write_commit = NULL; break;
    case 4: ops.write_abort = NULL; break;
    case 5: ops.read_begin = NULL; break;
    case 6: ops.read_end = NULL; break;
    default: ops.sync = NULL; break;
    }
    return ops;
}
