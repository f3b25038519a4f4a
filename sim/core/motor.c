/* motor.c: DC motor + gearhead + leg with PWM ripple on the measurements. See motor.h. */
#include "motor.h"

#include <math.h>
#include <string.h>

static const double PI = 3.14159265358979323846;

urbsim_motor_params_t urbsim_motor_default_params(void)
{
    /* A 20-W, 12-V graphite-brush DC motor of the Maxon RE 25 class with a 33:1 planetary
     * gearhead, as on RHex's hips; a SensoRHex leg (about 150 g, centre of mass 8 cm from the
     * hip) whose inertia about the hip dominates the reflected load; a 3S Li-Po supply. */
    urbsim_motor_params_t p;
    p.R = 1.2;
    p.L = 0.12e-3;
    p.Kt = 0.0165;
    p.Ke = 0.0165;
    p.Jm = 1.1e-6;
    p.Jleg = 2.4e-3;
    p.N = 33.0;
    p.eta = 0.8;
    p.b = 2.0e-6;
    p.tau_c = 1.5e-3;
    p.mgr = 0.15 * 9.81 * 0.08;
    p.Vs = 12.0;
    p.f_pwm = 40e3;
    p.tau_rc = 100e-6;
    p.current_noise = 0.02;
    p.voltage_noise = 0.02;
    p.counts_per_rev = 2000.0;
    p.C_th = 40.0;
    p.R_th = 6.0;
    p.T_amb = 25.0;
    p.step_ns = 100 * URBSIM_NS_PER_US;
    return p;
}

void urbsim_motor_init(urbsim_motor_t *m, const urbsim_motor_params_t *p, const urbsim_rng_t *rng)
{
    memset(m, 0, sizeof *m);
    m->p = *p;
    m->rng = *rng;
    m->temp = p->T_amb;
    m->pwm_phase0 = urbsim_rng_uniform(&m->rng);
    m->exp_arg = 0.0;
    m->exp_val = 1.0; /* exp(0) */
}

/* One integration step of dt seconds with the drive voltage held. */
static void step(urbsim_motor_t *m, double dt)
{
    const urbsim_motor_params_t *p = &m->p;
    /* Current: exact solution of the first-order electrical equation with w held. */
    double a = p->R / p->L;
    double i_ss = (m->v - p->Ke * m->w) / p->R;
    double x = -a * dt;
    if (x != m->exp_arg) {
        m->exp_arg = x;
        m->exp_val = exp(x);
    }
    double e = m->exp_val;
    double i_end = i_ss + (m->i - i_ss) * e;
    double i_avg = i_ss + (m->i - i_ss) * (1.0 - e) / (a * dt);
    /* Mechanics: semi-implicit Euler with the step's mean current. */
    double J = p->Jm + p->Jleg / (p->N * p->N);
    double leg = m->theta / p->N;
    double tau_load = p->mgr * sin(leg) / (p->N * p->eta);
    double drive = p->Kt * i_avg - tau_load;
    double w = m->w;
    if (fabs(w) < 1e-3 && fabs(drive) <= p->tau_c) {
        w = 0.0; /* static friction holds the shaft */
    } else {
        double fr = p->b * w + p->tau_c * (w > 0.0 ? 1.0 : (w < 0.0 ? -1.0 : (drive > 0.0 ? 1.0 : -1.0)));
        double w_new = w + dt * (drive - fr) / J;
        if (w != 0.0 && (w > 0.0) != (w_new > 0.0) && fabs(drive) <= p->tau_c) {
            w_new = 0.0; /* friction stops the shaft, it does not reverse it */
        }
        w = w_new;
    }
    m->theta += 0.5 * (m->w + w) * dt;
    m->w = w;
    m->i = i_end;
    m->temp += dt * (p->R * i_avg * i_avg - (m->temp - p->T_amb) / p->R_th) / p->C_th;
}

void urbsim_motor_advance(urbsim_motor_t *m, urbsim_ns_t t)
{
    while (m->t < t) {
        /* Steps end on multiples of step_ns, so the trajectory does not depend on query times. */
        urbsim_ns_t next = (m->t / m->p.step_ns + 1u) * m->p.step_ns;
        if (next > t) {
            next = t;
        }
        step(m, (double)(next - m->t) * 1e-9);
        m->t = next;
    }
}

void urbsim_motor_drive(urbsim_motor_t *m, urbsim_ns_t t, double volts)
{
    urbsim_motor_advance(m, t);
    if (volts > m->p.Vs) {
        volts = m->p.Vs;
    } else if (volts < -m->p.Vs) {
        volts = -m->p.Vs;
    }
    m->v = volts;
}

/* Position in the PWM period at t (0..1) and the duty cycle. */
static double pwm_phase(const urbsim_motor_t *m, urbsim_ns_t t)
{
    double periods = (double)t * 1e-9 * m->p.f_pwm + m->pwm_phase0;
    return periods - floor(periods);
}

/* A triangle of peak-to-peak pp, rising during the on-time d of the period, zero mean. */
static double triangle(double phase, double d, double pp)
{
    if (d <= 0.0 || d >= 1.0) {
        return 0.0;
    }
    return phase < d ? -pp / 2.0 + pp * phase / d : pp / 2.0 - pp * (phase - d) / (1.0 - d);
}

double urbsim_motor_sense_current(urbsim_motor_t *m, urbsim_ns_t t)
{
    urbsim_motor_advance(m, t);
    double d = fabs(m->v) / m->p.Vs;
    double pp = m->p.Vs * d * (1.0 - d) / (m->p.f_pwm * m->p.L);
    double ripple = triangle(pwm_phase(m, t), d, pp) * (m->v >= 0.0 ? 1.0 : -1.0);
    return m->i + ripple + urbsim_rng_normal(&m->rng, 0.0, m->p.current_noise);
}

double urbsim_motor_sense_voltage(urbsim_motor_t *m, urbsim_ns_t t)
{
    urbsim_motor_advance(m, t);
    double d = fabs(m->v) / m->p.Vs;
    double pp = m->p.Vs * d * (1.0 - d) / (m->p.f_pwm * m->p.tau_rc);
    double ripple = triangle(pwm_phase(m, t), d, pp) * (m->v >= 0.0 ? 1.0 : -1.0);
    return m->v + ripple + urbsim_rng_normal(&m->rng, 0.0, m->p.voltage_noise);
}

uint16_t urbsim_motor_encoder(urbsim_motor_t *m, urbsim_ns_t t)
{
    urbsim_motor_advance(m, t);
    double counts = floor(m->theta / (2.0 * PI) * m->p.counts_per_rev);
    int64_t c = (int64_t)counts;
    return (uint16_t)((uint64_t)c & 0xFFFFu);
}

double urbsim_motor_temperature(urbsim_motor_t *m, urbsim_ns_t t)
{
    urbsim_motor_advance(m, t);
    return m->temp;
}

double urbsim_motor_leg_angle(urbsim_motor_t *m, urbsim_ns_t t)
{
    urbsim_motor_advance(m, t);
    return m->theta / m->p.N;
}
