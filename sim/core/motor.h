/*
 * motor.h: a DC motor, gearhead and leg (one SensoRHex hip unit), for the motor driver node.
 *
 * MODEL (documented for users in sim/README.md, "Motor and leg"):
 *   electrical   L di/dt = v - R i - Ke w          (w: motor shaft speed, rad/s)
 *   mechanical   J dw/dt = Kt i - b w - friction - tau_leg / (N eta)
 *                J = Jm + Jleg / N^2, tau_leg = m g r sin(theta / N) (leg gravity, theta: motor angle)
 *                friction: Coulomb tau_c sign(w), sticking when |w| is tiny and the drive cannot
 *                overcome it
 *   drive        sign-magnitude PWM at f_pwm (40 kHz) from the supply Vs: the bridge applies
 *                +-Vs for a duty d = |v| / Vs of each period, so the average is v; the dynamics use
 *                the average (the electrical time constant L/R is several PWM periods), the
 *                measurements see the ripple:
 *   current      i(t) + the PWM triangle of peak-to-peak Vs d (1 - d) T / L at the sample's PWM
 *                phase, + N(0, current_noise) ADC noise, quantised to 1 mA
 *   voltage      the armature voltage after the node's RC filter (time constant tau_rc): the
 *                average v + a triangle of peak-to-peak Vs d (1 - d) T / tau_rc at the PWM phase,
 *                + N(0, voltage_noise), quantised to 1 mV
 *   encoder      floor(theta / 2 pi * counts_per_rev) modulo 65536 (quadrature counter)
 *   case temp    C dT/dt = R i^2 - (T - T_amb) / R_th
 * Integration: exact exponential step for the current over steps of at most `step_ns` with w held,
 * then semi-implicit Euler for w and theta; advanced lazily to each query (state is a pure
 * function of the command history, so the result does not depend on when it is queried).
 */
#ifndef URBSIM_MOTOR_H
#define URBSIM_MOTOR_H

#include <stdint.h>

#include "kernel.h"
#include "rng.h"

typedef struct {
    double R, L, Kt, Ke;        /**< ohm, H, Nm/A, V s/rad */
    double Jm, Jleg, N, eta;    /**< kg m^2 (rotor, leg about the hip), gear ratio, gear efficiency */
    double b, tau_c;            /**< viscous (Nm s/rad) and Coulomb (Nm) friction at the motor shaft */
    double mgr;                 /**< leg gravity torque amplitude m g r, Nm (0: leg horizontal plane) */
    double Vs, f_pwm;           /**< supply, V; PWM frequency, Hz */
    double tau_rc;              /**< voltage sense filter time constant, s */
    double current_noise, voltage_noise; /**< sd of the ADC noise, A and V */
    double counts_per_rev;      /**< encoder counts per motor revolution */
    double C_th, R_th, T_amb;   /**< thermal capacity J/K, resistance K/W, ambient degC */
    urbsim_ns_t step_ns;        /**< integration step (default 100 us) */
} urbsim_motor_params_t;

typedef struct {
    urbsim_motor_params_t p;
    urbsim_rng_t rng;
    urbsim_ns_t t;              /**< state valid at this virtual time */
    double i, w, theta, temp;   /**< current, speed, motor angle (rad), case temperature */
    double v;                   /**< commanded average armature voltage (clamped to +-Vs) */
    double pwm_phase0;          /**< PWM counter phase at t = 0, in periods */
    double exp_arg, exp_val;    /**< the last exp() of the current step: nearly every step has the
                                     same length, so it is computed once per motor, not per step */
} urbsim_motor_t;

/** SensoRHex hip defaults (see motor.c for the sources of the numbers). */
urbsim_motor_params_t urbsim_motor_default_params(void);

void urbsim_motor_init(urbsim_motor_t *m, const urbsim_motor_params_t *p, const urbsim_rng_t *rng);
/** Integrate up to virtual time t (no-op when t is not later than the state). */
void urbsim_motor_advance(urbsim_motor_t *m, urbsim_ns_t t);
/** The driver applies average armature voltage `volts` from time t on. */
void urbsim_motor_drive(urbsim_motor_t *m, urbsim_ns_t t, double volts);
/** Measurements at time t (ripple at the PWM phase of t, ADC noise). */
double urbsim_motor_sense_current(urbsim_motor_t *m, urbsim_ns_t t);
double urbsim_motor_sense_voltage(urbsim_motor_t *m, urbsim_ns_t t);
uint16_t urbsim_motor_encoder(urbsim_motor_t *m, urbsim_ns_t t);
double urbsim_motor_temperature(urbsim_motor_t *m, urbsim_ns_t t);
/** Leg angle (rad) = motor angle / N. */
double urbsim_motor_leg_angle(urbsim_motor_t *m, urbsim_ns_t t);

#endif /* URBSIM_MOTOR_H */
