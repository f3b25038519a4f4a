/*
 * SensoRHex battery manager node (see sensorhex_battery.h).
 */
#include "sensorhex_battery.h"

#include <stddef.h>

#include "urb_sensorhex.h"

void sensorhex_battery_defaults(sensorhex_battery_config_t *cfg, uint8_t index)
{
    cfg->index = index;
    cfg->empty_mv = 9900u;
    cfg->full_mv = 12600u;
    cfg->cutoff_mv = 10500u;
    cfg->resistance_mohm = 30u;
}

void sensorhex_battery_setup(sensorhex_battery_t *app, const sensorhex_battery_io_t *io,
                             const sensorhex_battery_config_t *cfg)
{
    app->io = io;
    app->cfg = *cfg;
    app->faults = 0u;
}

void sensorhex_battery_node_config(urb_node_config_t *cfg)
{
    cfg->update_divider = 10u; /* 100 Hz: the schema's rate */
    cfg->fw_major = 1u;
    cfg->fw_minor = 0u;
    cfg->fw_patch = 0u;
}

uint8_t sensorhex_battery_charge(const sensorhex_battery_config_t *cfg, uint16_t voltage_mv, int16_t current_ma)
{
    /* open-circuit voltage = terminal voltage + I * R (current positive when discharging) */
    int32_t const ocv = (int32_t)voltage_mv + ((int32_t)current_ma * (int32_t)cfg->resistance_mohm) / 1000;
    int32_t const span = (int32_t)cfg->full_mv - (int32_t)cfg->empty_mv;
    if ((span <= 0) || (ocv <= (int32_t)cfg->empty_mv)) {
        return 0u;
    }
    if (ocv >= (int32_t)cfg->full_mv) {
        return 100u;
    }
    int32_t const percent = ((ocv - (int32_t)cfg->empty_mv) * 100) / span; /* 0..99: empty < ocv < full */
    return (uint8_t)percent;
}

static void battery_bootup(urb_node_t *node, void *user)
{
    sensorhex_battery_t const *app = user;
    (void)urb_node_set_class(node, URB_NODE_BATTERY_MANAGER_CLASS);
    (void)urb_node_set_index(node, app->cfg.index);
    (void)urb_node_set_fingerprint(node, URB_NODE_BATTERY_MANAGER_FINGERPRINT);
    (void)urb_node_setup_outbox(node, URB_NODE_BATTERY_MANAGER_OUTBOX_BATTERY_STATUS,
                                URB_NODE_BATTERY_MANAGER_OUTBOX1_SIZE);
}

static void battery_update(urb_node_t *node, void *user)
{
    sensorhex_battery_t *app = user;
    sensorhex_battery_io_t const *io = app->io;
    urb_battery_status_t st;
    st.low = false;
    /* bound: SENSORHEX_BATTERY_PACKS = 3 */
    for (uint8_t i = 0u; i < SENSORHEX_BATTERY_PACKS; i++) {
        urb_battery_pack_t *p = &st.packs[i];
        p->present = io->present(io->ctx, i);
        p->voltage = 0u; /* an absent pack reports zeros */
        p->current = 0;
        p->temp = 0;
        p->charge = 0u;
        if (p->present) {
            p->voltage = io->voltage_mv(io->ctx, i);
            p->current = io->current_ma(io->ctx, i);
            p->temp = io->temp_c(io->ctx, i);
            p->charge = sensorhex_battery_charge(&app->cfg, p->voltage, p->current);
            if (p->voltage < app->cfg.cutoff_mv) {
                st.low = true;
            }
        }
    }
    st.charging = io->charger(io->ctx);
    uint8_t *out = NULL;
    if (urb_node_lock_outbox(node, URB_NODE_BATTERY_MANAGER_OUTBOX_BATTERY_STATUS, &out) == URB_NODE_OK) {
        (void)urb_battery_status_encode(&st, out, URB_BATTERY_STATUS_SIZE);
        (void)urb_node_release_outbox(node, URB_NODE_BATTERY_MANAGER_OUTBOX_BATTERY_STATUS);
    }
}

static void battery_fault(urb_node_t *node, void *user, urb_node_fault_t fault)
{
    (void)node;
    (void)fault;
    ((sensorhex_battery_t *)user)->faults++;
}

const urb_node_hooks_t sensorhex_battery_hooks = {battery_bootup, NULL, NULL, NULL, battery_update, NULL, battery_fault};
