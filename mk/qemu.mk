# Cortex-M0 execution under QEMU (tests/qemu). Included by the top-level Makefile. Outputs go to
# build/qemu/.
#   make qemu-test    build the test program for ARMv6-M with the cross builds' flags and strict
#                     warnings, run it on `qemu-system-arm -M microbit` (a Cortex-M0) under a timeout:
#                     the codec reference vectors (tests/vectors) and a node smoke test (SensoRHex
#                     motor driver on the node library and the hosted HAL); then the seeded bugs,
#                     each of which must make its run fail (a wrong expected byte: a failed check; an
#                     unaligned 32-bit load: a HardFault), and, as a control, the unaligned-load
#                     mutant on a Cortex-M3 (mps2-an385), where that load is legal and the run passes;
#                     then the Cortex-M0+ bridge port's clock across SysTick reloads, and its mutant
#   make qemu-build   only the images build/qemu/*.elf; run one with tests/qemu/run.sh ELF [vectors|node]

QEMU_BUILD := build/qemu
QEMU_CC ?= arm-none-eabi-gcc
QEMU_PYTHON ?= python3
QEMU_TIMEOUT ?= 20
QEMU_WARN := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
QEMU_CFLAGS := -mcpu=cortex-m0plus -mthumb -Os -g -ffunction-sections -fdata-sections
QEMU_INC := -Itests/qemu -I$(QEMU_BUILD)/gen -Ifirmware/include -Ifirmware/node -Ifirmware/hal/hosted \
            -Ifirmware/apps/sensorhex -Igen/c -Itests/firmware/node -Itests/c
QEMU_LD := tests/qemu/microbit.ld

# The node library (urb_single.c, the adapter with its own globals and app hooks, is not needed),
# the generated codecs, the hosted HAL, the motor app, the cmocka tests' I2C master, startup.
QEMU_SHARED_SRC := $(filter-out firmware/node/urb_single.c,$(wildcard firmware/node/urb_*.c)) $(wildcard gen/c/*.c) \
                   firmware/hal/hosted/urb_hal_hosted.c firmware/apps/sensorhex/sensorhex_motor.c \
                   tests/firmware/node/node_fixture.c tests/qemu/startup_microbit.c tests/qemu/semihost.c \
                   $(QEMU_BUILD)/gen/qt_vectors.c
QEMU_SHARED_OBJS := $(patsubst %.c,$(QEMU_BUILD)/obj/%.o,$(QEMU_SHARED_SRC))
QEMU_HDRS := $(wildcard tests/qemu/*.h firmware/include/*.h firmware/node/*.h firmware/hal/hosted/*.h \
               firmware/apps/sensorhex/*.h gen/c/*.h tests/firmware/node/*.h tests/c/*.h) $(QEMU_BUILD)/gen/qt_node.h

# Seeded bugs (#ifdefs in tests/qemu/qemu_main.c): -DURB_QEMU_MUTANT_<NAME>, and how the run must end.
QEMU_MUTANTS := EXPECTED_BYTE UNALIGNED_LOAD
qemu_expect_EXPECTED_BYTE := fail
qemu_expect_UNALIGNED_LOAD := hardfault

QEMU_ELF := $(QEMU_BUILD)/urb_qemu_test.elf
QEMU_MUTANT_ELFS := $(foreach m,$(QEMU_MUTANTS),$(QEMU_BUILD)/urb_qemu_mutant_$(m).elf)

.PHONY: qemu-test qemu-build

# The vectors as C tables and the node test's expected bytes (Python codecs); never committed.
$(QEMU_BUILD)/gen/qt_vectors.c $(QEMU_BUILD)/gen/qt_node.h &: tests/qemu/gen_tables.py \
        $(wildcard tests/vectors/*.json spec/schema/*.urbs gen/python/urb_msgs/*.py codegen/urb_codegen/*.py)
	$(QEMU_PYTHON) tests/qemu/gen_tables.py --out $(QEMU_BUILD)/gen

$(QEMU_BUILD)/obj/%.o: %.c $(QEMU_HDRS)
	@mkdir -p $(@D)
	$(QEMU_CC) $(QEMU_CFLAGS) $(QEMU_WARN) $(QEMU_INC) -c $< -o $@

$(QEMU_BUILD)/obj/main-normal.o: tests/qemu/qemu_main.c $(QEMU_HDRS)
	@mkdir -p $(@D)
	$(QEMU_CC) $(QEMU_CFLAGS) $(QEMU_WARN) $(QEMU_INC) -c $< -o $@

$(QEMU_BUILD)/obj/main-%.o: tests/qemu/qemu_main.c $(QEMU_HDRS)
	@mkdir -p $(@D)
	$(QEMU_CC) $(QEMU_CFLAGS) $(QEMU_WARN) $(QEMU_INC) -DURB_QEMU_MUTANT_$* -c $< -o $@

.PRECIOUS: $(QEMU_BUILD)/obj/%.o $(QEMU_BUILD)/obj/main-%.o

# No heap, no stdio: newlib-nano only for memcpy/memset/memcmp/strcmp; semihosting is tests/qemu/semihost.c.
qemu_link = $(QEMU_CC) -mcpu=cortex-m0plus -mthumb -nostartfiles -Wl,--gc-sections -T $(QEMU_LD) \
            --specs=nano.specs --specs=nosys.specs -Wl,-Map=$(@:.elf=.map) -o $@ $(1) $(QEMU_SHARED_OBJS) -lgcc

$(QEMU_ELF): $(QEMU_BUILD)/obj/main-normal.o $(QEMU_SHARED_OBJS) $(QEMU_LD)
	$(call qemu_link,$(QEMU_BUILD)/obj/main-normal.o)

$(QEMU_BUILD)/urb_qemu_mutant_%.elf: $(QEMU_BUILD)/obj/main-%.o $(QEMU_SHARED_OBJS) $(QEMU_LD)
	$(call qemu_link,$<)

# The bridge port's clock (tests/qemu/port_clock.c): the real Cortex-M0+ port file with its own
# vector table and linker script, at the nRF51's 16 MHz; and its seeded bug, the read that ignores
# a pending SysTick reload (time goes back by 1 ms), which must fail.
QEMU_PORT_SRC := tests/qemu/port_clock.c tests/qemu/semihost.c firmware/bridge/bridge.c firmware/bridge/bridge_uplink.c \
                 firmware/bridge/i2c_master.c gen/c/urb_core.c gen/c/urb_runtime.c
QEMU_PORT_DEPS := $(QEMU_PORT_SRC) firmware/hal/cortex-m0plus/bridge_port.c firmware/hal/cortex-m0plus/bridge_cm0plus.ld \
                  $(wildcard tests/qemu/*.h firmware/include/*.h firmware/bridge/*.h gen/c/*.h)
qemu_port_link = @mkdir -p $(@D) && $(QEMU_CC) $(QEMU_CFLAGS) $(QEMU_WARN) -DBRIDGE_CPU_HZ=16000000u $(1) \
                 -Itests/qemu -Ifirmware/hal/cortex-m0plus -Ifirmware/include -Igen/c -Ifirmware/bridge \
                 -nostartfiles -nostdlib -Wl,--gc-sections -T firmware/hal/cortex-m0plus/bridge_cm0plus.ld \
                 -o $@ $(QEMU_PORT_SRC) -lgcc

$(QEMU_BUILD)/port_clock.elf: $(QEMU_PORT_DEPS)
	$(call qemu_port_link,)

$(QEMU_BUILD)/port_clock_mutant.elf: $(QEMU_PORT_DEPS)
	$(call qemu_port_link,-DURB_MUTANT_CLOCK_IGNORES_PENDING)

qemu-build: $(QEMU_ELF) $(QEMU_MUTANT_ELFS) $(QEMU_BUILD)/port_clock.elf $(QEMU_BUILD)/port_clock_mutant.elf

qemu-test: qemu-build
	@QEMU_TIMEOUT=$(QEMU_TIMEOUT) tests/qemu/run.sh --expect pass --name "test program" $(QEMU_ELF)
	@$(foreach m,$(QEMU_MUTANTS),QEMU_TIMEOUT=$(QEMU_TIMEOUT) tests/qemu/run.sh --expect $(qemu_expect_$(m)) \
	  --name "mutant $(m)" $(QEMU_BUILD)/urb_qemu_mutant_$(m).elf || { echo "qemu-test: mutant $(m) was not caught as it must be ($(qemu_expect_$(m)))"; exit 1; };)
	@QEMU_TIMEOUT=$(QEMU_TIMEOUT) tests/qemu/run.sh --expect pass --quiet --machine mps2-an385 \
	  --name "control: mutant UNALIGNED_LOAD on a Cortex-M3, where unaligned LDR is legal," \
	  $(QEMU_BUILD)/urb_qemu_mutant_UNALIGNED_LOAD.elf node
	@QEMU_TIMEOUT=$(QEMU_TIMEOUT) tests/qemu/run.sh --expect pass --quiet --name "bridge port clock" $(QEMU_BUILD)/port_clock.elf
	@QEMU_TIMEOUT=$(QEMU_TIMEOUT) tests/qemu/run.sh --expect fail --name "mutant CLOCK_IGNORES_PENDING" \
	  $(QEMU_BUILD)/port_clock_mutant.elf || { echo "qemu-test: mutant CLOCK_IGNORES_PENDING was not caught"; exit 1; }
	@echo "qemu-test: the M0 programs passed, $(words $(QEMU_MUTANTS) x) of $(words $(QEMU_MUTANTS) x) mutants caught"

CHECK_TARGETS += qemu-test
