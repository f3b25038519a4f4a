# Bridge firmware (firmware/bridge, firmware/hal/*/bridge_*). Included by the top-level Makefile.
#   make test-firmware-bridge   cmocka tests under ASan+UBSan with gcc and clang, then the mutant
#                               check (every seeded bug must make the tests fail)
#   make bridge-mutants         the mutant check alone
#   make cross-bridge           Cortex-M0+ build of the bridge and its reference port (strict warnings)
#   make size-bridge            flash/RAM of the Cortex-M0+ bridge image (part of `make size`)
#   make bridge-hosted          build/firmware/urb-bridge-hosted: the bridge on a pseudo-terminal
#   make bridge-costs           callgrind instruction counts of the interrupt and per-request paths
#                               over worst-case inputs, with loop bounds: build/firmware/bridge_costs.md
# Outputs go to build/firmware/.

FWB_BUILD := build/firmware
FWB_STRICT := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
FWB_INC := -Ifirmware/include -Igen/c -Ifirmware/hal/hosted -Ifirmware/bridge
FWB_LIB_SRC := firmware/bridge/bridge.c firmware/bridge/bridge_uplink.c firmware/bridge/i2c_master.c
FWB_GEN_SRC := gen/c/urb_core.c gen/c/urb_runtime.c
FWB_HOSTED_SRC := firmware/hal/hosted/bridge_hosted.c firmware/hal/hosted/bridge_fake_i2c.c
FWB_TEST_SRC := $(filter-out tests/firmware/bridge/cost_driver.c,$(wildcard tests/firmware/bridge/*.c))
FWB_HDRS := $(wildcard firmware/include/urb_bridge*.h firmware/include/urb_downlink.h firmware/include/urb_i2c_event.h \
              firmware/include/urb_node.h firmware/include/urb_node_hal.h firmware/bridge/*.h \
              firmware/hal/hosted/bridge_*.h gen/c/*.h tests/firmware/bridge/*.h)
FWB_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FWB_TEST_CFLAGS := -std=c99 -Wall -Wextra -Werror -D_DEFAULT_SOURCE
FWB_MUTANTS := FIFO_OFF_BY_ONE DROP_WHEN_FULL NO_SEL_INVALIDATE REORDER NO_HUNT NO_GAP USB_OVERWRITE \
               NO_BUS_CLEAR SCAN_STOP_AT_GAP NO_PROBE USB_KEEP_EMPTY NO_BUDGET USB_HUNT \
               TABLE_FULL_OVERWRITE RX_NEWER_THAN_NOW NO_IDENTIFY_UNKNOWN
FWB_CROSS_CC ?= arm-none-eabi-gcc
FWB_CROSS_SIZE ?= arm-none-eabi-size
FWB_CROSS_NM ?= arm-none-eabi-nm
FWB_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections
FWB_CM0_SRC := $(FWB_LIB_SRC) $(FWB_GEN_SRC) $(wildcard firmware/hal/cortex-m0plus/bridge_*.c)

.PHONY: test-firmware-bridge bridge-tests bridge-mutants cross-bridge size-bridge bridge-hosted bridge-costs

# --- cmocka tests under sanitizers -------------------------------------------------------------
# The firmware and hosted HAL sources get the strict warning set; the test sources (cmocka macros)
# get -Wall -Wextra -Werror. One binary per compiler; its exit status counts failed tests.
define FWB_TEST_BINARY
$(FWB_BUILD)/$(1)/bridge-tests: $(FWB_LIB_SRC) $(FWB_GEN_SRC) $(FWB_HOSTED_SRC) $(FWB_TEST_SRC) $(FWB_HDRS)
	@mkdir -p $$(@D)/obj
	@for f in $(FWB_LIB_SRC) $(FWB_HOSTED_SRC) $(FWB_GEN_SRC); do \
	  $(1) $(FWB_STRICT) $(FWB_SAN) $(FWB_INC) -c $$$$f -o $$(@D)/obj/$$$$(basename $$$$f .c).o || exit 1; done
	@for f in $(FWB_TEST_SRC); do \
	  $(1) $(FWB_TEST_CFLAGS) $(FWB_SAN) $(FWB_INC) -c $$$$f -o $$(@D)/obj/t_$$$$(basename $$$$f .c).o || exit 1; done
	$(1) $(FWB_SAN) $$(@D)/obj/*.o -lcmocka -o $$@
endef
$(eval $(call FWB_TEST_BINARY,gcc))
$(eval $(call FWB_TEST_BINARY,clang))

# gcc prints cmocka's report (kept in junit/gcc-bridge-tests.log), clang writes JUnit XML; both go
# into the evidence record build/evidence/cmocka-bridge.json (report/urb_report/junit.py), which is
# written whether the tests passed or not.
bridge-tests: $(FWB_BUILD)/gcc/bridge-tests $(FWB_BUILD)/clang/bridge-tests
	@mkdir -p $(FWB_BUILD)/junit
	@rm -f $(FWB_BUILD)/junit/clang-bridge_*.xml
	@status=0; \
	CMOCKA_MESSAGE_OUTPUT=stdout $(FWB_BUILD)/gcc/bridge-tests 2>&1 | tee $(FWB_BUILD)/junit/gcc-bridge-tests.log; \
	[ $${PIPESTATUS[0]} -eq 0 ] || status=1; \
	CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE=$(FWB_BUILD)/junit/clang-%g.xml $(FWB_BUILD)/clang/bridge-tests \
	  > $(FWB_BUILD)/junit/clang-bridge-tests.out 2>&1 || { status=1; cat $(FWB_BUILD)/junit/clang-bridge-tests.out; }; \
	xmls=; for f in $(FWB_BUILD)/junit/clang-bridge_*.xml; do xmls="$$xmls --xml clang:bridge-tests=$$f"; done; \
	$(PYTHON) -m urb_report.junit cmocka --name cmocka-bridge $$xmls \
	  --log gcc:bridge-tests=$(FWB_BUILD)/junit/gcc-bridge-tests.log \
	  --rerun "make bridge-tests" --tool "gcc=$$(gcc --version | head -1)" \
	  --tool "clang=$$(clang --version | head -1)" || status=1; \
	[ $$status -eq 0 ] && echo "bridge tests: passed with gcc and clang (JUnit: $(FWB_BUILD)/junit/)"; exit $$status

# --- mutants: each seeded bug must be caught -----------------------------------------------------
# A mutant build compiles the same sources with -DURB_MUTANT_<NAME> (see the #ifdefs in
# firmware/bridge/); the check passes only when the test binary FAILS for every mutant.
# Only the three library sources carry mutants: the rest is compiled once and shared. No
# sanitizers here (a crash fails the run just as well) to keep the mutant builds quick.
FWB_MUT_COMMON := $(patsubst %.c,$(FWB_BUILD)/mutants/common/%.o,$(FWB_GEN_SRC) $(FWB_HOSTED_SRC) $(FWB_TEST_SRC))

$(FWB_BUILD)/mutants/common/%.o: %.c $(FWB_HDRS)
	@mkdir -p $(@D)
	@gcc $(FWB_TEST_CFLAGS) -g -O0 $(FWB_INC) -c $< -o $@

$(FWB_BUILD)/mutants/%/bridge-tests: $(FWB_LIB_SRC) $(FWB_MUT_COMMON) $(FWB_HDRS)
	@mkdir -p $(@D)
	@gcc $(FWB_TEST_CFLAGS) -g -O0 -DURB_MUTANT_$* $(FWB_INC) $(FWB_LIB_SRC) $(FWB_MUT_COMMON) -lcmocka -o $@

$(FWB_BUILD)/mutants/%.caught: $(FWB_BUILD)/mutants/%/bridge-tests
	@if CMOCKA_MESSAGE_OUTPUT=stdout $< > $(FWB_BUILD)/mutants/$*.log 2>&1; then \
	  echo "mutant $*: SURVIVED (the tests pass with the seeded bug)"; exit 1; \
	else \
	  failed="$$(grep '^\[  FAILED  \] [a-z_0-9]*$$' $(FWB_BUILD)/mutants/$*.log | sed 's/.*\] //' | sort -u)"; \
	  echo "mutant $*: caught by $$(echo "$$failed" | wc -l) test(s): $$(echo $$failed | cut -c1-120)"; \
	  touch $@; fi

.PRECIOUS: $(FWB_BUILD)/mutants/%/bridge-tests
.SECONDARY: $(FWB_MUT_COMMON)

bridge-mutants:
	@rm -f $(FWB_BUILD)/mutants/*.caught
	@$(MAKE) --no-print-directory $(patsubst %,$(FWB_BUILD)/mutants/%.caught,$(FWB_MUTANTS))
	@echo "bridge mutants: all $(words $(FWB_MUTANTS)) caught"

test-firmware-bridge: bridge-tests
	@$(MAKE) --no-print-directory bridge-mutants

# --- Cortex-M0+ ------------------------------------------------------------------------------------
$(FWB_BUILD)/cortex-m0plus/%.o: %.c $(FWB_HDRS)
	@mkdir -p $(@D)
	$(FWB_CROSS_CC) $(FWB_CROSS_FLAGS) $(FWB_STRICT) -Ifirmware/include -Igen/c -Ifirmware/bridge -c $< -o $@

FWB_CM0_OBJS := $(patsubst %.c,$(FWB_BUILD)/cortex-m0plus/%.o,$(FWB_CM0_SRC))

$(FWB_BUILD)/urb-bridge-cm0plus.elf: $(FWB_CM0_OBJS) firmware/hal/cortex-m0plus/bridge_cm0plus.ld
	$(FWB_CROSS_CC) $(FWB_CROSS_FLAGS) -nostartfiles -nostdlib -Wl,--gc-sections \
	  -T firmware/hal/cortex-m0plus/bridge_cm0plus.ld -Wl,-Map=$(@:.elf=.map) $(FWB_CM0_OBJS) -lgcc -o $@

cross-bridge: $(FWB_BUILD)/urb-bridge-cm0plus.elf
	@echo "cross-bridge: Cortex-M0+ bridge image builds with $(FWB_STRICT)"

size-bridge: $(FWB_BUILD)/urb-bridge-cm0plus.elf
	@echo "Bridge firmware, Cortex-M0+ (-Os), per object (library code):"
	@$(FWB_CROSS_SIZE) $(patsubst %.c,$(FWB_BUILD)/cortex-m0plus/%.o,$(FWB_LIB_SRC) $(FWB_GEN_SRC))
	@echo "Linked reference image (library + generated codecs + port skeleton, --gc-sections):"
	@$(FWB_CROSS_SIZE) $<
	@echo "State objects (bytes):"
	@$(FWB_CROSS_NM) -S -t d --size-sort $< | awk '$$4 ~ /^g_(bridge|master|usb_buf)$$/ {printf "  %-10s %6d\n", $$4, $$2 + 0}'

SIZE_TARGETS += size-bridge

# --- hosted bridge program -------------------------------------------------------------------------
# --downlink can (firmware/hal/hosted/hosted_can.c): the CAN master on tools/can_hub.py
FWB_HOSTED_CAN_SRC := firmware/hal/hosted/hosted_can.c firmware/hal/hosted/can_hub_client.c firmware/hal/hosted/hub_socket.c firmware/downlink/can/urb_can_master.c \
                      firmware/downlink/can/urb_can_transfer.c gen/c/urb_can_wire.c
# --downlink rs485 (firmware/hal/hosted/hosted_rs485.c): the RS485 master on tools/rs485_hub.py
FWB_HOSTED_RS485_SRC := firmware/hal/hosted/hosted_rs485.c firmware/hal/hosted/rs485_hub_client.c \
                      firmware/downlink/rs485/urb_rs485_master.c firmware/downlink/rs485/urb_rs485_frame.c gen/c/urb_rs485_wire.c
# URB_MUTANT=NAME builds the seeded bug NAME in: build/firmware/urb-bridge-hosted-NAME (tests/host/test_hosted_downlinks.py)
FWB_HOSTED_BIN := $(FWB_BUILD)/urb-bridge-hosted$(if $(URB_MUTANT),-$(URB_MUTANT))
$(FWB_HOSTED_BIN): firmware/bridge/hosted_main.c $(FWB_LIB_SRC) $(FWB_GEN_SRC) $(FWB_HOSTED_SRC) $(FWB_HOSTED_CAN_SRC) $(FWB_HOSTED_RS485_SRC) $(FWB_HDRS) \
                   $(wildcard firmware/hal/hosted/*.h firmware/include/urb_can*.h firmware/include/urb_rs485*.h)
	@mkdir -p $(@D)
	gcc $(FWB_STRICT) -D_DEFAULT_SOURCE -D_XOPEN_SOURCE=600 -O2 $(if $(URB_MUTANT),-DURB_MUTANT_$(URB_MUTANT)) $(FWB_INC) \
	  firmware/bridge/hosted_main.c $(FWB_LIB_SRC) $(FWB_GEN_SRC) gen/c/urb_sensorhex.c $(FWB_HOSTED_SRC) $(FWB_HOSTED_CAN_SRC) \
	  $(FWB_HOSTED_RS485_SRC) -o $@

bridge-hosted: $(FWB_HOSTED_BIN)

# --- worst-case instruction counts -----------------------------------------------------------------
$(FWB_BUILD)/bridge-cost-driver: tests/firmware/bridge/cost_driver.c $(FWB_LIB_SRC) $(FWB_GEN_SRC) $(FWB_HOSTED_SRC) $(FWB_HDRS)
	@mkdir -p $(@D)
	gcc -std=c99 -Wall -Wextra -Werror -O2 -g -fno-inline-functions-called-once $(FWB_INC) \
	  tests/firmware/bridge/cost_driver.c $(FWB_LIB_SRC) $(FWB_GEN_SRC) $(FWB_HOSTED_SRC) -o $@

bridge-costs: $(FWB_BUILD)/bridge-cost-driver
	$(PYTHON) tests/firmware/bridge/cost_table.py --driver $< --out $(FWB_BUILD)/bridge_costs.md

CHECK_TARGETS += test-firmware-bridge cross-bridge bridge-hosted bridge-costs
