"""The SensoRHex hip motor for the downlink comparison's control loop: sim/core/motor.c's default
parameters (motor, gearhead, leg), idealised: the armature current follows the voltage at once
(L / R = 0.1 ms against a 1-ms loop), no PWM ripple, no ADC noise, the leg in the horizontal plane
(no gravity), as Figs. 18-19's runs. Integrated at 100 us steps (semi-implicit Euler)."""

from __future__ import annotations

import math
from dataclasses import dataclass

R, KT, KE = 1.2, 0.0165, 0.0165          # ohm, Nm/A, V s/rad
JM, JLEG, N, ETA = 1.1e-6, 2.4e-3, 33.0, 0.8
B, TAU_C = 2.0e-6, 1.5e-3                # viscous Nm s/rad and Coulomb Nm at the motor shaft
VS = 12.0
STEP_S = 100e-6


@dataclass
class Motor:
    """Motor angle and speed (rad, rad/s at the motor shaft) and the applied voltage."""

    theta: float = 0.0
    w: float = 0.0
    volts: float = 0.0
    t: float = 0.0

    def drive(self, volts: float) -> None:
        self.volts = max(-VS, min(VS, volts))

    def advance(self, t: float) -> None:
        j = JM + (JLEG / (N * N)) / ETA
        while self.t + 1e-12 < t:
            h = min(STEP_S, t - self.t)
            i = (self.volts - KE * self.w) / R
            friction = TAU_C * math.tanh(self.w / 0.5)
            self.w += h * (KT * i - B * self.w - friction) / j
            self.theta += h * self.w
            self.t += h
