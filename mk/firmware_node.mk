# Node firmware (firmware/node, firmware/hal/{hosted,cortex-m0plus}, firmware/apps/sensorhex).
# Included by the top-level Makefile (`include mk/*.mk`). Outputs go to build/firmware/node/.
#
#   make test-firmware-node   cmocka unit tests under ASan+UBSan with gcc AND clang, then the
#                             mutant check (every seeded bug must make the tests fail)
#   make cross-firmware-node  node library, reference port and SensoRHex apps for Cortex-M0+ (-Os,
#                             the strict warning set), linked into one image per app
#   make size-node            flash/RAM of the node library and of each app image
#   make size                 every firmware size report and budget (see SIZE_TARGETS below; in make check)
#   make wcet-node            callgrind instruction counts of the interrupt handlers + loop bounds
#   make pll-harness          the two-node PLL harness: convergence, inter-node error, jitter
#
# SIZE_TARGETS convention (shared with the bridge fragment): every firmware fragment APPENDS its
# size target to SIZE_TARGETS (`SIZE_TARGETS += size-bridge`) and defines no `size` rule of its
# own. The one `size` rule is here; it runs $(SIZE_TARGETS) from its recipe, which make expands
# after reading every fragment, so the include order of mk/*.mk does not matter.

SIZE_TARGETS += size-node

.PHONY: size
size:
	@$(MAKE) --no-print-directory $(SIZE_TARGETS)

FWN_BUILD := build/firmware/node
FWN_WARN := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
FWN_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FWN_INC := -Ifirmware/include -Ifirmware/node -Ifirmware/hal/hosted -Ifirmware/apps/sensorhex -Igen/c \
           -Itests/firmware/node -Itests/firmware/pll
FWN_CROSS_CC ?= arm-none-eabi-gcc
FWN_CROSS_SIZE ?= arm-none-eabi-size
FWN_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections
FWN_PYTHON ?= python3

FWN_LIB_SRC := firmware/node/urb_mailbox.c firmware/node/urb_i2c.c firmware/node/urb_pll.c firmware/node/urb_node.c \
               firmware/node/urb_observe.c
FWN_GEN_SRC := gen/c/urb_runtime.c gen/c/urb_core.c gen/c/urb_sensorhex.c
FWN_HOSTED_SRC := firmware/hal/hosted/urb_hal_hosted.c
FWN_APPS := motor battery imu ir
FWN_APP_SRC := $(foreach a,$(FWN_APPS),firmware/apps/sensorhex/sensorhex_$(a).c)
FWN_SINGLE_SRC := firmware/node/urb_single.c
FWN_HDRS := $(wildcard firmware/include/*.h firmware/node/*.h firmware/hal/hosted/*.h firmware/apps/sensorhex/*.h \
            gen/c/*.h tests/firmware/node/*.h tests/firmware/pll/*.h)

# ===== Unit tests: objects per compiler, one program per tests/firmware/node/test_*.c ============

FWN_TESTS := test_mailbox test_i2c test_node test_interleave test_pll test_apps test_single
FWN_COMPILERS := gcc clang
FWN_COMMON_SRC := tests/firmware/node/node_fixture.c $(FWN_LIB_SRC) $(FWN_GEN_SRC) $(FWN_HOSTED_SRC)
fwn_extra_test_pll := tests/firmware/pll/pll_model.c
fwn_extra_test_apps := $(FWN_APP_SRC)
fwn_extra_test_single := $(FWN_SINGLE_SRC)
fwn_objs = $(patsubst %.c,$(FWN_BUILD)/$(1)/obj/%.o,tests/firmware/node/$(2).c $(FWN_COMMON_SRC) $(fwn_extra_$(2)))

# $(1): compiler
define FWN_CC_RULES
$(FWN_BUILD)/$(1)/obj/%.o: %.c $(FWN_HDRS)
	@mkdir -p $$(@D)
	$(1) $(FWN_WARN) $(FWN_SAN) -DURB_NODE_TESTING $(FWN_INC) -c $$< -o $$@
endef
$(foreach cc,$(FWN_COMPILERS),$(eval $(call FWN_CC_RULES,$(cc))))

# $(1): compiler, $(2): test name
define FWN_TEST_RULE
$(FWN_BUILD)/$(1)/$(2): $(call fwn_objs,$(1),$(2))
	$(1) $(FWN_SAN) -o $$@ $$^ -lcmocka -lm
endef
$(foreach cc,$(FWN_COMPILERS),$(foreach t,$(FWN_TESTS),$(eval $(call FWN_TEST_RULE,$(cc),$(t)))))

FWN_TEST_BINS := $(foreach cc,$(FWN_COMPILERS),$(foreach t,$(FWN_TESTS),$(FWN_BUILD)/$(cc)/$(t)))

.PHONY: test-firmware-node fwn-unit fwn-mutants cross-firmware-node size-node wcet-node wcet-node-check pll-harness

# gcc builds print cmocka's report; clang builds write JUnit XML to build/firmware/node/junit/.
fwn-unit: $(FWN_TEST_BINS)
	@tests/firmware/node/run_unit.sh $(FWN_BUILD) $(FWN_TEST_BINS)

# Every URB_MUTANT_* must make at least one test program fail (tests/firmware/node/run_mutants.sh).
fwn-mutants:
	@tests/firmware/node/run_mutants.sh $(FWN_BUILD)/mutants

test-firmware-node: fwn-unit fwn-mutants cross-firmware-node

# ===== PLL harness ==============================================================================

$(FWN_BUILD)/pll_harness: tests/firmware/pll/pll_harness.c tests/firmware/pll/pll_model.c $(FWN_LIB_SRC) \
                          gen/c/urb_runtime.c gen/c/urb_core.c $(FWN_HDRS)
	@mkdir -p $(@D)
	gcc $(FWN_WARN) -O2 $(FWN_INC) -o $@ tests/firmware/pll/pll_harness.c tests/firmware/pll/pll_model.c \
	    $(FWN_LIB_SRC) gen/c/urb_runtime.c gen/c/urb_core.c -lm

pll-harness: $(FWN_BUILD)/pll_harness
	$(FWN_BUILD)/pll_harness

# ===== Cortex-M0+ cross build ===================================================================

FWN_X := $(FWN_BUILD)/cortex-m0plus
FWN_X_INC := -Ifirmware/include -Ifirmware/node -Ifirmware/hal/cortex-m0plus -Ifirmware/apps/sensorhex \
             -Ifirmware/apps/sensorhex/targets -Igen/c
FWN_X_PORT_SRC := firmware/hal/cortex-m0plus/urb_hal_cm0.c firmware/hal/cortex-m0plus/startup_cm0.c \
                  firmware/apps/sensorhex/targets/board_cm0.c
FWN_X_LD := firmware/hal/cortex-m0plus/cm0plus.ld
FWN_X_LIB_OBJS := $(patsubst %.c,$(FWN_X)/obj/%.o,$(FWN_LIB_SRC))
FWN_X_COMMON_OBJS := $(patsubst %.c,$(FWN_X)/obj/%.o,$(FWN_GEN_SRC) $(FWN_X_PORT_SRC))
FWN_X_IMAGES := $(foreach a,$(FWN_APPS),$(FWN_X)/sensorhex_$(a).elf)

$(FWN_X)/obj/%.o: %.c $(FWN_HDRS) $(wildcard firmware/hal/cortex-m0plus/*.h firmware/apps/sensorhex/targets/*.h)
	@mkdir -p $(@D)
	$(FWN_CROSS_CC) $(FWN_CROSS_FLAGS) $(FWN_WARN) $(FWN_X_INC) -c $< -o $@

# Objects reached through pattern rules would count as intermediate and be deleted: keep them.
.PRECIOUS: $(FWN_X)/obj/%.o $(FWN_X)/obj/firmware/apps/sensorhex/targets/main_%.o $(FWN_BUILD)/gcc/obj/%.o $(FWN_BUILD)/clang/obj/%.o

$(FWN_X)/liburb_node.a: $(FWN_X_LIB_OBJS)
	rm -f $@
	arm-none-eabi-ar rcs $@ $^

# One main per app, all from main_node.c: the application name selects its functions and storage.
$(FWN_X)/obj/firmware/apps/sensorhex/targets/main_%.o: firmware/apps/sensorhex/targets/main_node.c $(FWN_HDRS) \
        $(wildcard firmware/hal/cortex-m0plus/*.h firmware/apps/sensorhex/targets/*.h)
	@mkdir -p $(@D)
	$(FWN_CROSS_CC) $(FWN_CROSS_FLAGS) $(FWN_WARN) $(FWN_X_INC) -DSENSORHEX_APP=$* \
	    -DSENSORHEX_APP_STORAGE=SENSORHEX_$(shell echo $* | tr a-z A-Z)_STORAGE -c $< -o $@

# One image per app: main + app + board stubs + port + startup + codecs + the library archive.
$(FWN_X)/sensorhex_%.elf: $(FWN_X)/obj/firmware/apps/sensorhex/targets/main_%.o \
                          $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_%.o $(FWN_X_COMMON_OBJS) \
                          $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_battery.o \
                          $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_imu.o \
                          $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_ir.o \
                          $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_motor.o \
                          $(FWN_X)/liburb_node.a $(FWN_X_LD)
	$(FWN_CROSS_CC) -mcpu=cortex-m0plus -mthumb -Os -nostartfiles -Wl,--gc-sections -T $(FWN_X_LD) \
	    --specs=nano.specs --specs=nosys.specs -Wl,-Map=$(@:.elf=.map) -o $@ \
	    $(FWN_X)/obj/firmware/apps/sensorhex/targets/main_$*.o $(FWN_X)/obj/firmware/apps/sensorhex/sensorhex_$*.o \
	    $(FWN_X_COMMON_OBJS) $(FWN_X)/liburb_node.a -lgcc

# The size probe: sizeof(urb_node_t) on the target, read back with nm.
$(FWN_X)/size_probe.o: tests/firmware/node/size_probe.c $(FWN_HDRS)
	@mkdir -p $(@D)
	$(FWN_CROSS_CC) $(FWN_CROSS_FLAGS) $(FWN_WARN) $(FWN_X_INC) -c $< -o $@

cross-firmware-node: $(FWN_X)/liburb_node.a $(FWN_X_IMAGES) $(FWN_X)/obj/$(FWN_SINGLE_SRC:.c=.o) $(FWN_X)/size_probe.o

size-node: cross-firmware-node
	@$(FWN_PYTHON) tests/firmware/node/size_report.py --size $(FWN_CROSS_SIZE) --lib $(FWN_X_LIB_OBJS) \
	    --single $(FWN_X)/obj/$(FWN_SINGLE_SRC:.c=.o) --probe $(FWN_X)/size_probe.o --images $(FWN_X_IMAGES)

# ===== Worst-case instruction counts (callgrind) ================================================

FWN_WCET_SRC := tests/firmware/node/wcet_driver.c tests/firmware/node/node_fixture.c $(FWN_LIB_SRC) \
                gen/c/urb_runtime.c gen/c/urb_core.c $(FWN_HOSTED_SRC)
$(FWN_BUILD)/wcet_driver: $(FWN_WCET_SRC) $(FWN_HDRS)
	@mkdir -p $(@D)
	gcc $(FWN_WARN) -O2 -g -fno-ipa-icf $(FWN_INC) -o $@ $(FWN_WCET_SRC)

wcet-node: $(FWN_BUILD)/wcet_driver
	@$(FWN_PYTHON) tests/firmware/node/wcet.py --driver $(FWN_BUILD)/wcet_driver --out $(FWN_BUILD)/wcet.md

# The README's handler table is the measurement (about 1 s; the counts are those of Debian's gcc 12).
wcet-node-check: $(FWN_BUILD)/wcet_driver
	@$(FWN_PYTHON) tests/firmware/node/wcet.py --driver $(FWN_BUILD)/wcet_driver --out $(FWN_BUILD)/wcet.md \
	    --readme firmware/node/README.md --quiet

# size: every firmware's flash and RAM budget (a budget that is exceeded fails the check)
CHECK_TARGETS += test-firmware-node wcet-node-check size
