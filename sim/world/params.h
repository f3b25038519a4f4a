/*
 * params.h: every tunable of the simulation, with its default and meaning (one table: the C
 * world reads it, `urb sim params` prints it, sim/README.md documents the same table).
 * X(ID, "name", default, "meaning")
 */
#ifndef URBSIM_PARAMS_H
#define URBSIM_PARAMS_H

#define URBSIM_PARAMS(X)                                                                              \
    X(NODE_PPM_MEAN, "node.ppm_mean", 0.0, "mean crystal frequency error of the nodes, ppm")         \
    X(NODE_PPM_SD, "node.ppm_sd", 30.0, "sd of each node's crystal error, drawn per node and seed, ppm") \
    X(NODE_WANDER_PPM, "node.wander_ppm", 0.2, "sd of the slow random wander of a node's crystal, ppm") \
    X(NODE_WANDER_TAU, "node.wander_tau_s", 30.0, "time constant of that wander, s")                 \
    X(NODE_RAMP, "node.ramp_ppm_per_s", 0.0, "deterministic drift of every node's error (warm-up), ppm/s") \
    X(NODE_CPU_HZ, "node.cpu_hz", 48e6, "node core clock (Cortex-M0+), Hz")                           \
    X(NODE_TICKS_PER_US, "node.ticks_per_us", 48.0, "node heartbeat timer ticks per us (timer resolution)") \
    X(NODE_IRQ_CYCLES, "node.irq_cycles", 15.0, "node interrupt entry latency, core cycles")          \
    X(NODE_IRQ_JITTER, "node.irq_jitter_cycles", 4.0, "extra node interrupt latency, uniform 0..N cycles") \
    X(NODE_I2C_ISR, "node.i2c_isr_cycles", 60.0, "node I2C slave handler length (clock stretching), cycles") \
    X(NODE_TIMER_ISR, "node.timer_isr_cycles", 120.0, "node heartbeat handler length, cycles")       \
    X(NODE_WAKE, "node.wake_cycles", 30.0, "node main loop wake-up after an interrupt, cycles")       \
    X(NODE_POLL, "node.poll_cycles", 300.0, "node main-loop iteration without acquisition, cycles")  \
    X(NODE_ACQ_US, "node.acq_us", 50.0, "node acquisition time in app_update (sensor reads), us")    \
    X(NODE_ACQ_JITTER, "node.acq_jitter_cycles", 4.0, "extra acquisition time, uniform 0..N cycles (instruction-level)") \
    X(NODE_SYNC_CAPTURE, "node.sync_capture", 0.0, "1: SYNC time-stamped by input capture, 0: in the ISR") \
    X(NODE_SYNC, "node.sync", 1.0, "1: heartbeat locked to SYNC (paper Fig. 12), 0: free-running (Fig. 11)") \
    X(NODE_LEAD_US, "node.lead_us", 0.0, "fixed phase lead, us; 0 = the measured acquisition time")   \
    X(NODE_HEARTBEAT_US, "node.heartbeat_us", 1000.0, "node nominal heartbeat period, us")           \
    X(NODE_KD_Q8, "node.kd_q8", 32.0, "node PLL K_d of eq. 1 in 1/256 (urb_node_config_t.kd_q8)")                \
    X(NODE_KN_Q8, "node.kn_q8", 64.0, "node PLL K_n of eq. 2 in 1/256 (urb_node_config_t.kn_q8)")                \
    X(NODE_OUTLIER_NS, "node.outlier_ns", 2000.0, "node PLL: phase or period error rejected as an outlier, ns (urb_node_config_t.outlier_ns, at most 65535)") \
    X(NODE_MAX_OUTLIERS, "node.max_outliers", 4.0, "node PLL: outliers in a row before re-acquiring (urb_node_config_t.max_outliers)") \
    X(NODE_ACQ_WINDOW, "node.acq_window", 16.0, "node t_acq window, updates (urb_node_config_t.acq_window)")   \
    X(NODE_ACQ_GUARD, "node.acq_guard_us", 1.0, "node guard added to t_acq, us (urb_node_config_t.acq_guard_us)") \
    X(NODE_BOOT_MS, "node.boot_spread_ms", 20.0, "nodes power on at uniform times in 0..N ms")        \
    X(NODE_SCL_TIMEOUT, "node.scl_timeout_ms", 25.0, "node I2C peripheral's SCL low timeout (SMBus t_TIMEOUT), ms") \
    X(NODE_FLASH_WS, "node.flash_ws", 0.0, "node flash wait states: +2 per interrupt entry, +0..1 entry jitter each, handlers x (1 + ws/2)") \
    X(NODE_MASK_CYCLES, "node.mask_cycles", 0.0, "node main loop's PRIMASK section before WFI (interrupts wait for its end), cycles") \
    X(NODE_IDLE_CYCLES, "node.idle_cycles", 0.0, "node main-loop pass from a handler's return to that masked section, cycles") \
    X(NODE_WFI_WAKE, "node.wfi_wake_cycles", 0.0, "node wake-up from WFI (sleep mode) before the interrupt entry, cycles") \
    X(NODE_VTH_MIN, "node.vth_min", 0.5, "lowest node input threshold, fraction of VDD (drawn per node in [min, max])") \
    X(NODE_VTH_MAX, "node.vth_max", 0.5, "highest node input threshold, fraction of VDD") \
    X(NODE_FILTER_MIN, "node.filter_ns_min", 0.0, "shortest node I2C input glitch-filter delay, ns (drawn per node)") \
    X(NODE_FILTER_MAX, "node.filter_ns_max", 0.0, "longest node I2C input glitch-filter delay, ns") \
    X(NODE_I2C_CLK, "node.i2c_clk_hz", 48e6, "node I2C peripheral kernel clock (input synchroniser), Hz") \
    X(NODE_SYNC_MIN, "node.i2c_sync_min_cycles", 0.0, "fewest kernel-clock cycles to synchronise a bus edge") \
    X(NODE_SYNC_MAX, "node.i2c_sync_max_cycles", 0.0, "most kernel-clock cycles to synchronise a bus edge (uniform per edge)") \
    X(BRIDGE_PPM_MEAN, "bridge.ppm_mean", 0.0, "mean crystal error of the bridges, ppm")             \
    X(BRIDGE_PPM_SD, "bridge.ppm_sd", 30.0, "sd of each bridge's crystal error, ppm")                 \
    X(BRIDGE_WANDER_PPM, "bridge.wander_ppm", 0.2, "sd of a bridge crystal's slow wander, ppm")       \
    X(BRIDGE_CPU_HZ, "bridge.cpu_hz", 48e6, "bridge core clock, Hz")                                  \
    X(BRIDGE_IRQ_CYCLES, "bridge.irq_cycles", 15.0, "bridge interrupt entry latency, cycles")         \
    X(BRIDGE_IRQ_JITTER, "bridge.irq_jitter_cycles", 4.0, "extra bridge interrupt latency, 0..N cycles") \
    X(BRIDGE_I2C_ISR, "bridge.i2c_isr_cycles", 80.0, "bridge I2C master handler length, cycles")      \
    X(BRIDGE_UART_ISR, "bridge.uart_isr_cycles", 60.0, "bridge UART handler length, cycles")          \
    X(BRIDGE_TIMER_ISR, "bridge.timer_isr_cycles", 40.0, "bridge heartbeat handler length, cycles")   \
    X(BRIDGE_USB_ISR, "bridge.usb_isr_cycles", 200.0, "bridge USB handler length, cycles")            \
    X(BRIDGE_WAKE, "bridge.wake_cycles", 30.0, "bridge main loop wake-up, cycles")                    \
    X(BRIDGE_POLL, "bridge.poll_cycles", 200.0, "bridge main-loop iteration, cycles")                 \
    X(BRIDGE_BUSY_POLL_US, "bridge.busy_poll_us", 50.0, "main-loop period while the bridge is busy, us") \
    X(BRIDGE_HEARTBEAT_US, "bridge.heartbeat_us", 1000.0, "SYNC period, us (0: no SYNC)")            \
    X(BRIDGE_FIFO, "bridge.fifo_depth", 16.0, "bridge request FIFO depth")                            \
    X(BRIDGE_BAUD, "bridge.baud", 115200.0, "RS232 uplink bit rate, Bd")                              \
    X(BRIDGE_DIVIDER, "bridge.uart_divider_hz", 48e6, "bridge baud generator clock (0: exact baud), Hz") \
    X(BRIDGE_SCAN, "bridge.scan_at_start", 1.0, "1: the bridge scans its downlink at power-on")      \
    X(BRIDGE_HB_SOF, "bridge.heartbeat_sof", 0.0, "1: USB bridges derive the heartbeat from USB SOF (SYNC aligned with frames)") \
    X(BRIDGE_BOOT_MS, "bridge.boot_ms", 25.0, "bridges power on at this time, ms (after the nodes)")  \
    X(BRIDGE_FLASH_WS, "bridge.flash_ws", 0.0, "bridge flash wait states (as node.flash_ws)")              \
    X(BRIDGE_MASK_CYCLES, "bridge.mask_cycles", 0.0, "bridge main loop's PRIMASK section before WFI, cycles") \
    X(BRIDGE_IDLE_CYCLES, "bridge.idle_cycles", 0.0, "bridge main-loop pass from a handler's return to that section, cycles") \
    X(BRIDGE_WFI_WAKE, "bridge.wfi_wake_cycles", 0.0, "bridge wake-up from WFI before the interrupt entry, cycles") \
    X(I2C_BITRATE, "i2c.bitrate", 400e3, "downlink I2C bit rate, b/s")                                \
    X(I2C_BUS_PF, "i2c.bus_pf", 0.0, "downlink bus capacitance, pF (0: ideal edges, every node sees them at once)") \
    X(I2C_PULLUP, "i2c.pullup_ohm", 0.0, "downlink pull-up resistance (rising edges), ohm") \
    X(I2C_SINK_MA, "i2c.sink_ma", 3.0, "current pulling SCL/SDA low (falling edges), mA")              \
    X(I2C_VDD, "i2c.vdd", 3.3, "bus supply, V")                                                        \
    X(CPU_PPM_MEAN, "cpu.ppm_mean", 0.0, "mean crystal error of the host CPU, ppm")                  \
    X(CPU_PPM_SD, "cpu.ppm_sd", 50.0, "sd of the host CPU's crystal error, ppm")                      \
    X(CPU_TICK_US, "cpu.tick_us", 1000.0, "OS tick period (1 kHz Linux), us")                         \
    X(CPU_TIMER_WAKE_US, "cpu.timer_wake_us", 5.0, "a sleeping thread runs this long after its tick, us") \
    X(CPU_TIMER_JITTER_US, "cpu.timer_jitter_us", 15.0, "plus uniform 0..N us of scheduling jitter") \
    X(CPU_IO_WAKE_US, "cpu.io_wake_us", 20.0, "a thread blocked on I/O runs this long after the interrupt, us") \
    X(CPU_IO_JITTER_US, "cpu.io_jitter_us", 30.0, "plus uniform 0..N us")                            \
    X(USB_PPM_SD, "usb.ppm_sd", 50.0, "sd of the USB host controller crystal error, ppm")             \
    X(USB_HC_IRQ_US, "usb.hc_irq_us", 20.0, "host controller completion interrupt to driver callback, us") \
    X(USB_PHASE_US, "usb.phase_us", -1.0, "USB frame phase against the OS tick, us (-1: drawn per seed)") \
    X(USB_BITRATE, "usb.bitrate", 12e6, "USB bus bit rate (full speed), b/s")                         \
    X(USB_NAK_NEXT_FRAME, "usb.nak_next_frame", 0.0, "1: a NAKed transaction is retried in the next frame; 0: in its frame, after the frame's other transactions") \
    X(USB_READ_ALWAYS, "usb.read_always", 1.0, "1: the driver keeps a bulk-IN pending every frame; 0: reads only after a write (Fig. 9)") \
    X(MOTOR_JLEG, "motor.leg_inertia", 2.4e-3, "leg inertia about the hip, kg m^2")                \
    X(MOTOR_MGR, "motor.leg_gravity", 1.1772, "leg gravity torque m g r, Nm (0: no gravity)")         \
    X(MOTOR_N, "motor.gear_ratio", 33.0, "gearhead ratio")                                            \
    X(MOTOR_VS, "motor.supply_v", 12.0, "motor supply (3S Li-Po), V")                                \
    X(MOTOR_PWM, "motor.pwm_hz", 40e3, "motor PWM frequency, Hz")                                   \
    X(PROBE_CLASS, "probe.class_id", 126.0, "class of probe nodes")                                  \
    X(PROBE_FINGERPRINT, "probe.fingerprint", 2119565312.0, "layout fingerprint probe nodes report")  \
    X(PROBE_OUT, "probe.out_size", 6.0, "probe outbox 1 size, bytes")                                 \
    X(PROBE_IN, "probe.in_size", 0.0, "probe inbox 1 size, bytes (0: none)")                         \
    X(PROBE_FILL, "probe.fill_counter", 0.0, "1: every probe outbox byte carries the update counter (trace validation)") \
    X(SCOPE_SAMPLE, "scope.sample_ns", 0.0, "Table I's marks as an oscilloscope samples them: sample period, ns (0: true time)") \
    X(SCOPE_SKEW, "scope.skew_ns", 0.0, "largest fixed skew of one mark's path (pin, probe, channel), ns (drawn per node)") \
    X(SCOPE_PPM, "scope.ppm", 0.0, "the oscilloscope's timebase error against true time, ppm") \
    X(SCOPE_CAPTURE, "scope.capture_periods", 0.0, "Table I read once per run, as from one oscilloscope capture at a trigger drawn in the steady state: the inter-node difference of that cycle, a node's period peak to peak over this many periods (0: statistics over the whole steady state)")

#define URBSIM_PARAM_ENUM(id, name, def, doc) P_##id,
enum { URBSIM_PARAMS(URBSIM_PARAM_ENUM) P_COUNT };
#undef URBSIM_PARAM_ENUM

#endif /* URBSIM_PARAMS_H */
