# Cortex-M0+ (STM32G0B1) images on the CAN and RS485 downlinks, and the register-level ports' tests
# (issue #39). Included by the top-level Makefile after mk/node_downlinks.mk (name order), whose
# per-downlink node library archives the node images link.
#   make cross-cm0-downlinks   build/firmware/cm0_dl/urb-node-cm0plus-{can,rs485}.elf (echo node on the
#                              FDCAN / USART-RS485 port, firmware/hal/cortex-m0plus/node_dl_cm0.c) and
#                              urb-bridge-cm0plus-{can,rs485}.elf (bridge_port.c with the CAN / RS485 master)
#   make size-cm0-downlinks    their flash and RAM next to the I2C builds' (part of `make size`)
#   make test-cm0hal           tests/firmware/cm0hal: the FDCAN and USART ports compiled for the host
#                              against RAM register blocks (gcc and clang, ASan+UBSan), and the images
#   make cm0hal-qemu           the same four test programs built for ARMv6-M (arm-none-eabi-gcc -Os, a cmocka
#                              subset over semihosting: tests/firmware/cm0hal/qemu) and run on QEMU's Cortex-M0
#                              (-M microbit, tests/qemu/run.sh), and one seeded bug that must fail there
#   make cm0hal-mutants        the seeded bugs of tests/firmware/cm0hal/mutants.json, each of which must
#                              fail the tests it names (tests/firmware/cm0hal/test_cm0hal_seeded_bugs.py;
#                              make test-py runs the same file, so make check runs them once)
# Outputs go to build/firmware/cm0_dl/.

CM0DL_BUILD := build/firmware/cm0_dl
CM0DL_CC ?= arm-none-eabi-gcc
CM0DL_SIZE ?= arm-none-eabi-size
CM0DL_STRICT := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
CM0DL_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections
CM0DL_INC := -Ifirmware/include -Ifirmware/node -Ifirmware/bridge -Ifirmware/hal/cortex-m0plus -Ifirmware/apps/echo -Igen/c
CM0DL_PORT_HDRS := $(wildcard firmware/hal/cortex-m0plus/*.h firmware/include/*.h firmware/node/*.h firmware/bridge/*.h \
                   firmware/apps/echo/*.h gen/c/*.h)
CM0DL_PORT_can := firmware/hal/cortex-m0plus/urb_cm0_fdcan.c
CM0DL_PORT_rs485 := firmware/hal/cortex-m0plus/urb_cm0_usart485.c
CM0DL_DEF_can :=
CM0DL_DEF_rs485 := -DURB_CM0_NODE_RS485
CM0DL_NODE_SHARED := firmware/hal/cortex-m0plus/startup_cm0.c firmware/apps/echo/echo_app.c gen/c/urb_core.c gen/c/urb_runtime.c
CM0DL_NODE_ARCHIVE = build/firmware/node_dl/cortex-m0plus/$(1)/liburb_node.a
CM0DL_BRIDGE_LIB := firmware/bridge/bridge.c firmware/bridge/bridge_uplink.c gen/c/urb_core.c gen/c/urb_runtime.c
CM0DL_BRIDGE_can := firmware/downlink/can/urb_can_master.c firmware/downlink/can/urb_can_transfer.c gen/c/urb_can_wire.c
CM0DL_BRIDGE_rs485 := firmware/downlink/rs485/urb_rs485_master.c firmware/downlink/rs485/urb_rs485_frame.c \
                      gen/c/urb_rs485_wire.c
CM0DL_BRIDGE_DEF_can := -DURB_BRIDGE_DOWNLINK_CAN
CM0DL_BRIDGE_DEF_rs485 := -DURB_BRIDGE_DOWNLINK_RS485

.PHONY: cross-cm0-downlinks size-cm0-downlinks test-cm0hal cm0hal-tests cm0hal-mutants cm0hal-qemu

# $(1): can or rs485. Node image: the glue, the port, startup, echo, codecs, the library archive
# for that downlink; bridge image: bridge_port.c with the master, the port, the bridge library.
define CM0DL_RULES
$(CM0DL_BUILD)/urb-node-cm0plus-$(1).elf: firmware/hal/cortex-m0plus/node_dl_cm0.c $(CM0DL_PORT_$(1)) $(CM0DL_NODE_SHARED) \
        $(call CM0DL_NODE_ARCHIVE,$(1)) firmware/hal/cortex-m0plus/cm0plus.ld $(CM0DL_PORT_HDRS)
	@mkdir -p $$(@D)
	$(CM0DL_CC) $(CM0DL_FLAGS) $(CM0DL_STRICT) $(CM0DL_INC) $(CM0DL_DEF_$(1)) -nostartfiles -Wl,--gc-sections \
	    -T firmware/hal/cortex-m0plus/cm0plus.ld --specs=nano.specs --specs=nosys.specs -Wl,-Map=$$(@:.elf=.map) -o $$@ \
	    firmware/hal/cortex-m0plus/node_dl_cm0.c $(CM0DL_PORT_$(1)) $(CM0DL_NODE_SHARED) $(call CM0DL_NODE_ARCHIVE,$(1)) -lgcc

$(CM0DL_BUILD)/urb-bridge-cm0plus-$(1).elf: firmware/hal/cortex-m0plus/bridge_port.c $(CM0DL_PORT_$(1)) $(CM0DL_BRIDGE_LIB) \
        $(CM0DL_BRIDGE_$(1)) firmware/hal/cortex-m0plus/bridge_cm0plus.ld $(CM0DL_PORT_HDRS)
	@mkdir -p $$(@D)
	$(CM0DL_CC) $(CM0DL_FLAGS) $(CM0DL_STRICT) $(CM0DL_INC) $(CM0DL_BRIDGE_DEF_$(1)) -nostartfiles -nostdlib -Wl,--gc-sections \
	    -T firmware/hal/cortex-m0plus/bridge_cm0plus.ld -Wl,-Map=$$(@:.elf=.map) -o $$@ \
	    firmware/hal/cortex-m0plus/bridge_port.c $(CM0DL_PORT_$(1)) $(CM0DL_BRIDGE_LIB) $(CM0DL_BRIDGE_$(1)) -lgcc
endef
$(foreach d,can rs485,$(eval $(call CM0DL_RULES,$(d))))

CM0DL_IMAGES := $(foreach d,can rs485,$(CM0DL_BUILD)/urb-node-cm0plus-$(d).elf $(CM0DL_BUILD)/urb-bridge-cm0plus-$(d).elf)
CM0DL_I2C_IMAGES := build/firmware/node/cortex-m0plus/sensorhex_motor.elf build/firmware/urb-bridge-cm0plus.elf

cross-cm0-downlinks: $(CM0DL_IMAGES)
	@echo "cross-cm0-downlinks: CAN and RS485 node and bridge images build with $(CM0DL_STRICT)"

# flash = .text + .data (the initial values), RAM = .data + .bss (the stack comes on top)
size-cm0-downlinks: $(CM0DL_IMAGES) $(CM0DL_I2C_IMAGES)
	@echo "Cortex-M0+ images per downlink (-Os, --gc-sections; flash = text + data, RAM = data + bss, stack not counted):"
	@$(CM0DL_SIZE) -B $(CM0DL_I2C_IMAGES) $(CM0DL_IMAGES) | awk 'NR > 1 { printf "  %-58s flash %6d B  RAM %6d B\n", $$6, $$1 + $$2, $$2 + $$3 }'
	@echo "  (the I2C node image is the SensoRHex motor app; its library's 4 KiB budget is checked by size-node)"

SIZE_TARGETS += size-cm0-downlinks

# ===== Host tests of the register-level ports ====================================================
CM0HAL_TESTS := test_cm0_can test_cm0_rs485 test_cm0_can_node test_cm0_rs485_node
CM0HAL_SRC_test_cm0_can := tests/firmware/cm0hal/test_cm0_can.c firmware/hal/cortex-m0plus/urb_cm0_fdcan.c
# the port with the node library's CAN build behind it (the lists of mk/node_downlinks.mk)
CM0HAL_SRC_test_cm0_can_node := tests/firmware/cm0hal/test_cm0_can_node.c firmware/hal/cortex-m0plus/urb_cm0_fdcan.c \
                                firmware/apps/echo/echo_app.c firmware/node/urb_mailbox.c firmware/node/urb_pll.c \
                                firmware/node/urb_node.c firmware/node/urb_observe.c firmware/node/urb_node_dl.c \
                                firmware/node/urb_node_can.c firmware/downlink/can/urb_can_slave.c \
                                firmware/downlink/can/urb_can_transfer.c gen/c/urb_can_wire.c gen/c/urb_core.c gen/c/urb_runtime.c
CM0HAL_SRC_test_cm0_rs485_node := tests/firmware/cm0hal/test_cm0_rs485_node.c tests/firmware/cm0hal/usart_line.c \
                                  firmware/hal/cortex-m0plus/urb_cm0_usart485.c firmware/apps/echo/echo_app.c \
                                  firmware/node/urb_mailbox.c firmware/node/urb_pll.c firmware/node/urb_node.c \
                                  firmware/node/urb_observe.c firmware/node/urb_node_dl.c firmware/node/urb_node_rs485.c \
                                  firmware/downlink/rs485/urb_rs485_slave.c firmware/downlink/rs485/urb_rs485_frame.c \
                                  gen/c/urb_rs485_wire.c gen/c/urb_core.c gen/c/urb_runtime.c
CM0HAL_SRC_test_cm0_rs485 := tests/firmware/cm0hal/test_cm0_rs485.c tests/firmware/cm0hal/usart_line.c \
                             firmware/hal/cortex-m0plus/urb_cm0_usart485.c
CM0HAL_INC := -DURB_CM0_USART_TEST_HOOK -Ifirmware/include -Ifirmware/node -Ifirmware/hal/cortex-m0plus -Ifirmware/apps/echo \
              -Igen/c -Itests/firmware/cm0hal
CM0HAL_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
CM0HAL_HDRS := $(wildcard firmware/hal/cortex-m0plus/urb_cm0_*.h tests/firmware/cm0hal/*.h firmware/include/*.h \
               firmware/node/*.h firmware/apps/echo/*.h gen/c/*.h)

define CM0HAL_RULE
$(CM0DL_BUILD)/$(1)/$(2): $(CM0HAL_SRC_$(2)) $(CM0HAL_HDRS)
	@mkdir -p $$(@D)
	@$(1) $(CM0DL_STRICT) -D_DEFAULT_SOURCE $(CM0HAL_SAN) $(CM0HAL_INC) $(CM0HAL_SRC_$(2)) -lcmocka -o $$@
endef
$(foreach cc,gcc clang,$(foreach t,$(CM0HAL_TESTS),$(eval $(call CM0HAL_RULE,$(cc),$(t)))))
CM0HAL_BINS := $(foreach cc,gcc clang,$(foreach t,$(CM0HAL_TESTS),$(CM0DL_BUILD)/$(cc)/$(t)))

# gcc prints cmocka's report, clang writes JUnit XML; both go into build/evidence/cmocka-cm0hal.json
cm0hal-tests: $(CM0HAL_BINS)
	@mkdir -p $(CM0DL_BUILD)/junit && rm -f $(CM0DL_BUILD)/junit/*.xml $(CM0DL_BUILD)/junit/*.log
	@status=0; xmls=; logs=; for t in $(CM0HAL_TESTS); do \
	  CMOCKA_MESSAGE_OUTPUT=stdout $(CM0DL_BUILD)/gcc/$$t > $(CM0DL_BUILD)/junit/gcc-$$t.log 2>&1 || { status=1; cat $(CM0DL_BUILD)/junit/gcc-$$t.log; }; \
	  echo "gcc $$t: $$(grep -c '^\[       OK \]' $(CM0DL_BUILD)/junit/gcc-$$t.log) passed"; \
	  CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE=$(CM0DL_BUILD)/junit/clang-$$t.xml $(CM0DL_BUILD)/clang/$$t \
	    > $(CM0DL_BUILD)/junit/clang-$$t.out 2>&1 || { status=1; cat $(CM0DL_BUILD)/junit/clang-$$t.out; }; \
	  xmls="$$xmls --xml clang:$$t=$(CM0DL_BUILD)/junit/clang-$$t.xml"; \
	  logs="$$logs --log gcc:$$t=$(CM0DL_BUILD)/junit/gcc-$$t.log"; done; \
	$(PYTHON) -m urb_report.junit cmocka --name cmocka-cm0hal $$xmls $$logs --rerun "make cm0hal-tests" \
	  --tool "gcc=$$(gcc --version | head -1)" --tool "clang=$$(clang --version | head -1)" || status=1; \
	[ $$status -eq 0 ] && echo "cm0hal tests: passed with gcc and clang (JUnit: $(CM0DL_BUILD)/junit/)"; exit $$status

# every seeded bug of mutants.json must make its test program fail, in the tests it names
cm0hal-mutants:
	@$(PYTHON) -m pytest -q -p no:cacheprovider tests/firmware/cm0hal/test_cm0hal_seeded_bugs.py

# ===== The same tests on a Cortex-M0 (QEMU) ========================================================
CM0HAL_QEMU := $(CM0DL_BUILD)/qemu
CM0HAL_QEMU_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -g -ffunction-sections -fdata-sections
CM0HAL_QEMU_SUPPORT := tests/firmware/cm0hal/qemu/cmocka_m0.c tests/qemu/startup_microbit.c tests/qemu/semihost.c
CM0HAL_QEMU_DEPS := $(CM0HAL_QEMU_SUPPORT) tests/firmware/cm0hal/qemu/cmocka.h tests/qemu/semihost.h tests/qemu/microbit.ld \
                    $(CM0HAL_HDRS)
# the seeded bug the QEMU run must catch (an entry of mutants.json, applied to a copy of its file)
CM0HAL_QEMU_MUTANT := tx-id-wrong-field
cm0hal_qemu_link = @mkdir -p $(@D) && $(CM0DL_CC) $(CM0HAL_QEMU_FLAGS) $(CM0DL_STRICT) -Itests/firmware/cm0hal/qemu -Itests/qemu \
                   $(CM0HAL_INC) -nostartfiles -Wl,--gc-sections -T tests/qemu/microbit.ld --specs=nano.specs \
                   --specs=nosys.specs -o $@ $(1) $(CM0HAL_QEMU_SUPPORT) -lgcc

define CM0HAL_QEMU_RULE
$(CM0HAL_QEMU)/$(1).elf: $(CM0HAL_SRC_$(1)) $(CM0HAL_QEMU_DEPS)
	$$(call cm0hal_qemu_link,$(CM0HAL_SRC_$(1)))
endef
$(foreach t,$(CM0HAL_TESTS),$(eval $(call CM0HAL_QEMU_RULE,$(t))))

$(CM0HAL_QEMU)/mutant/urb_cm0_fdcan.c: firmware/hal/cortex-m0plus/urb_cm0_fdcan.c tests/firmware/cm0hal/mutants.json
	@mkdir -p $(@D)
	@$(PYTHON) -c "import json, sys; m = [x for x in json.load(open('tests/firmware/cm0hal/mutants.json')) \
	  if x['name'] == '$(CM0HAL_QEMU_MUTANT)'][0]; s = open(m['file']).read(); assert s.count(m['find']) == 1; \
	  open(sys.argv[1], 'w').write(s.replace(m['find'], m['replace']))" $@

$(CM0HAL_QEMU)/test_cm0_can-mutant.elf: $(CM0HAL_SRC_test_cm0_can) $(CM0HAL_QEMU)/mutant/urb_cm0_fdcan.c $(CM0HAL_QEMU_DEPS)
	$(call cm0hal_qemu_link,tests/firmware/cm0hal/test_cm0_can.c $(CM0HAL_QEMU)/mutant/urb_cm0_fdcan.c)

cm0hal-qemu: $(foreach t,$(CM0HAL_TESTS),$(CM0HAL_QEMU)/$(t).elf) $(CM0HAL_QEMU)/test_cm0_can-mutant.elf
	@for t in $(CM0HAL_TESTS); do \
	  QEMU_TIMEOUT=60 tests/qemu/run.sh --expect pass --quiet --name "$$t" $(CM0HAL_QEMU)/$$t.elf || exit 1; done
	@QEMU_TIMEOUT=60 tests/qemu/run.sh --expect fail --name "test_cm0_can with the seeded bug $(CM0HAL_QEMU_MUTANT)" \
	  $(CM0HAL_QEMU)/test_cm0_can-mutant.elf || { echo "cm0hal-qemu: the seeded bug was not caught"; exit 1; }

test-cm0hal: cm0hal-tests
	@$(MAKE) --no-print-directory cm0hal-qemu cross-cm0-downlinks

CHECK_TARGETS += test-cm0hal
