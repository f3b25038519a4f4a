/*
 * sim_host_pd.c: the PD and gait axes on the C host (see sim_host_c.h, urbsim_chost_axis): the
 * SensoRHex loop of sim/urb_sim/experiments/control.py (_control) and gait.py (run_gait), operation
 * for operation, so that the two host libraries compute the same commands.
 */
#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "sim_host_c_internal.h"
#include "urb_sensorhex.h"

#define PI 3.141592653589793 /* Python's math.pi, so that the two hosts compute the same positions */
#define FEEDBACK_MAILBOX 1u
#define COMMAND_MAILBOX 1u

static void push_sample(urbsim_chost_t *h, ch_axis_t *a, int64_t t, double pos, double ref)
{
    /* three arrays of one length: each grows from the same capacity to the same capacity */
    uint32_t cap_t = a->cap_s, cap_p = a->cap_s, cap_r = a->cap_s;
    bool ok = chost_grow((void **)&a->st, &cap_t, a->n_s + 1u, sizeof *a->st);
    ok = chost_grow((void **)&a->spos, &cap_p, a->n_s + 1u, sizeof *a->spos) && ok;
    ok = chost_grow((void **)&a->sref, &cap_r, a->n_s + 1u, sizeof *a->sref) && ok;
    if (!ok || cap_t != cap_p || cap_t != cap_r) {
        h->errors++;
        return;
    }
    a->cap_s = cap_t;
    a->st[a->n_s] = t;
    a->spos[a->n_s] = pos;
    a->sref[a->n_s] = ref;
    a->n_s++;
}

/* The Pd of control.py: u = Kp e + Kd de/dt, de/dt over the reads' submission instants. */
static double pd(ch_axis_t *a, double e, int64_t t_ns)
{
    double de = 0.0;
    if (a->has_prev) {
        double dt = (double)(t_ns - a->prev_t) * 1e-9;
        de = (e - a->prev_e) / (dt > 1e-6 ? dt : 1e-6);
    }
    a->has_prev = true;
    a->prev_e = e;
    a->prev_t = t_ns;
    double u = a->kp * e + a->kd * de;
#ifdef URBSIM_MUTANT_CHOST_WRONG_GAIN
    u = 1.25 * a->kp * e + a->kd * de; /* seeded bug: the proportional gain 25 % high */
#endif
    return u > a->limit ? a->limit : (u < -a->limit ? -a->limit : u);
}

/* Axis.update: the encoder wraps modulo 65536 (Python's % is never negative). */
static double unwrap(ch_axis_t *a, uint16_t raw)
{
    if (a->has_raw) {
        int64_t d = ((int64_t)raw - (int64_t)a->raw + 32768) % 65536;
        a->pos += (d < 0 ? d + 65536 : d) - 32768;
    }
    a->raw = raw;
    a->has_raw = true;
    return (double)a->pos / (2000.0 / (2.0 * PI));
}

/* Submit the MotorCommand for drive u (V), as int(round(u * 1000)) mV; false when it failed. */
static bool command(urbsim_chost_t *h, ch_axis_t *a, double u)
{
    double mv = rint(u * 1000.0); /* Python's round(): halves to even, the default rounding mode */
    if (!chost_grow((void **)&a->mv, &a->cap_mv, a->n_mv + 1u, sizeof *a->mv)) {
        h->errors++;
        return false;
    }
    urb_motor_command_t cmd = {(int16_t)mv};
    uint8_t data[URB_MOTOR_COMMAND_SIZE];
    xfer_t *w = chost_xfer_get(h);
    if (!w || urb_motor_command_encode(&cmd, data, sizeof data) != (int32_t)sizeof data ||
        urb_transfer_write(&w->t, a->address, COMMAND_MAILBOX, data, (uint8_t)sizeof data) != URB_HOST_OK) {
        h->errors++;
        if (w) {
            chost_xfer_put(h, w);
        }
        return false;
    }
    w->axis = -1;
    chost_submit(h, w, a->bridge);
    a->mv[a->n_mv++] = (int32_t)mv;
    return true;
}

/* gait.py's Buehler clock, gait clock and leg reference, operation for operation. */
#define GEAR 33.0
#define PERIOD_S 0.8
#define STANCE_SWEEP 1.0
#define DUTY 0.5

static double buehler(double phase_s)
{
    double k = floor(phase_s / PERIOD_S);
    double t = phase_s - k * PERIOD_S;
    double a;
    if (t < DUTY * PERIOD_S) {
        a = -STANCE_SWEEP / 2 + STANCE_SWEEP * t / (DUTY * PERIOD_S);
    } else {
        a = STANCE_SWEEP / 2 + (2 * PI - STANCE_SWEEP) * (t - DUTY * PERIOD_S) / ((1 - DUTY) * PERIOD_S);
    }
    return a + 2 * PI * k + STANCE_SWEEP / 2;
}

static double gait_clock(double t_s)
{
    if (t_s < PERIOD_S) {
        return t_s;
    }
    double back = 2 * PERIOD_S - t_s;
    return back > 0.0 ? back : 0.0;
}

static double leg_reference(int leg, double t_s)
{
    double offset = (leg == 0 || leg == 2 || leg == 4) ? 0.0 : PERIOD_S / 2;
    return GEAR * (buehler(gait_clock(t_s) + offset) - buehler(offset));
}

/* The feedback callback of gait.py's run_gait. */
static void gait_feedback(urbsim_chost_t *h, ch_axis_t *a, const urb_motor_feedback_t *fb, int64_t submitted)
{
    int64_t now = urbsim_host_local(h->w);
    int64_t t = now - h->t0;
    double pos = unwrap(a, fb->encoder);
    double ts = (double)t * 1e-9;
    double ref = leg_reference(a->leg, ts > 0.0 ? ts : 0.0);
    double u = pd(a, ref - pos, submitted ? submitted : now);
    if (!command(h, a, u)) {
        return;
    }
    double plant[6];
    if (urbsim_node_plant(h->w, a->node, plant) != 0 ||
        !chost_grow((void **)&a->log, &a->cap_log, (a->n_log + 1u) * CH_LOG_COLS, sizeof *a->log)) {
        h->errors++;
        return;
    }
    double *row = &a->log[a->n_log++ * CH_LOG_COLS];
    row[0] = (double)t * 1e-9;
    row[1] = ref;
    row[2] = plant[0];
    row[3] = fb->voltage / 1000.0;
    row[4] = fb->current / 1000.0;
    row[5] = plant[2];
}

/* The feedback callback of control.py's _control (or gait.py's run_gait for a gait axis). */
void chost_pd_done(urbsim_chost_t *h, xfer_t *x)
{
    ch_axis_t *a = &h->axis[x->axis];
    urb_motor_feedback_t fb;
    if (x->t.flags != URB_FLAG_NONE ||
        urb_motor_feedback_decode(&fb, x->t.response, x->t.response_len) != (int32_t)URB_MOTOR_FEEDBACK_SIZE) {
        a->fails++;
        return;
    }
    if (a->leg >= 0) {
        gait_feedback(h, a, &fb, x->t.submitted_ns);
        return;
    }
    int64_t t = urbsim_host_local(h->w);
    double pos = unwrap(a, fb.encoder);
    double r = a->amp * sin(a->omega * (double)(t - h->t0) * 1e-9);
    (void)command(h, a, pd(a, r - pos, x->t.submitted_ns ? x->t.submitted_ns : t));
}

/* control.py's tick: every PD axis's true angle sampled, then every axis's feedback read submitted. */
bool chost_pd_tick(urbsim_chost_t *h)
{
    int64_t t = urbsim_host_local(h->w) - h->t0;
    for (int i = 0; i < h->n_axes; i++) {
        ch_axis_t *a = &h->axis[i];
        if (a->leg >= 0) {
            continue; /* a gait axis logs at its feedback, not at the tick */
        }
        double plant[6];
        if (urbsim_node_plant(h->w, a->node, plant) != 0) {
            h->errors++;
            return false;
        }
        push_sample(h, a, t, plant[0], a->amp * sin(a->omega * (double)t * 1e-9));
    }
    for (int i = 0; i < h->n_axes; i++) {
        xfer_t *x = chost_xfer_get(h);
        if (!x) {
            return false;
        }
        urb_transfer_read(&x->t, h->axis[i].address, FEEDBACK_MAILBOX, URB_MOTOR_FEEDBACK_SIZE);
        x->axis = i;
        chost_submit(h, x, h->axis[i].bridge);
    }
    return true;
}

void chost_pd_free(urbsim_chost_t *h)
{
    for (int i = 0; i < h->n_axes; i++) {
        free(h->axis[i].st);
        free(h->axis[i].spos);
        free(h->axis[i].sref);
        free(h->axis[i].mv);
        free(h->axis[i].log);
    }
}

int urbsim_chost_axis(urbsim_chost_t *h, int bridge, int node, int address, double kp, double kd, double limit,
                      double amp, double omega, int leg)
{
    if (!h || h->n_axes == CH_MAX_AXES || leg > 5 || bridge < 0 || bridge >= CH_MAX_BRIDGES || !h->b[bridge].on || address < 1 ||
        address > 127 || !(limit > 0.0)) {
        return -1;
    }
    double plant[6];
    if (urbsim_node_plant(h->w, node, plant) != 0) {
        return -1;
    }
    ch_axis_t *a = &h->axis[h->n_axes];
    memset(a, 0, sizeof *a);
    *a = (ch_axis_t){.bridge = bridge, .node = node, .leg = leg < 0 ? -1 : leg, .address = (uint8_t)address, .kp = kp,
                     .kd = kd, .limit = limit, .amp = amp, .omega = omega};
    return h->n_axes++;
}

/* The axis `axis` of `h`, or NULL when there is no such axis. */
static const ch_axis_t *axis_at(const urbsim_chost_t *h, int axis)
{
    return (h && axis >= 0 && axis < h->n_axes) ? &h->axis[axis] : NULL;
}

/* How many of the `have` entries recorded, starting at `from`, fit in `cap`. */
static uint32_t span(uint32_t from, uint32_t have, uint32_t cap)
{
    if (from >= have) {
        return 0;
    }
    return (have - from < cap) ? have - from : cap;
}

int urbsim_chost_samples(urbsim_chost_t *h, int axis, uint32_t from, int64_t *t, double *pos, double *ref, uint32_t cap)
{
    const ch_axis_t *a = axis_at(h, axis);
    if (!a || !t || !pos || !ref) {
        return -1;
    }
    uint32_t const n = span(from, a->n_s, cap);
    if (n > 0) {
        memcpy(t, &a->st[from], n * sizeof *t);
        memcpy(pos, &a->spos[from], n * sizeof *pos);
        memcpy(ref, &a->sref[from], n * sizeof *ref);
    }
    return (int)n;
}

int urbsim_chost_commands(urbsim_chost_t *h, int axis, uint32_t from, int32_t *mv, uint32_t cap)
{
    const ch_axis_t *a = axis_at(h, axis);
    if (!a || !mv) {
        return -1;
    }
    uint32_t const n = span(from, a->n_mv, cap);
    if (n > 0) {
        memcpy(mv, &a->mv[from], n * sizeof *mv);
    }
    return (int)n;
}

int urbsim_chost_log(urbsim_chost_t *h, int axis, uint32_t from, double *rows, uint32_t cap)
{
    const ch_axis_t *a = axis_at(h, axis);
    if (!a || !rows) {
        return -1;
    }
    uint32_t const n = span(from, a->n_log, cap);
    if (n > 0) {
        memcpy(rows, &a->log[(size_t)from * CH_LOG_COLS], (size_t)n * CH_LOG_COLS * sizeof *rows);
    }
    return (int)n;
}
