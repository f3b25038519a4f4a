# The node library on each downlink (issue #39 phase 2). Included by the top-level Makefile.
#   URB_DOWNLINK=i2c|can|rs485   the downlink a node library archive is built for (default i2c):
#                                make node-lib-downlink URB_DOWNLINK=can -> build/firmware/node_dl/cortex-m0plus/can/liburb_node.a
#                                i2c links firmware/node/urb_i2c.c (the port calls urb_node_i2c_event); can and
#                                rs485 link urb_node_dl.c, urb_node_<dl>.c and the downlink's slave in its place
#                                (the port drives urb_node_<dl>_t.slave; urb_node_downlink.h)
#   make size-node-downlinks     flash of the node library per downlink on Cortex-M0+ (part of `make size`)
#   make test-node-downlinks     tests/firmware/node_dl: one host sequence and one node application on I2C, CAN
#                                and RS485 (test_three_downlinks), the bridge firmware's error flags per failure
#                                kind on each downlink (test_bridge_flags); gcc and clang under ASan+UBSan; then
#                                the seeded bugs, each of which must make its program fail
# Outputs go to build/firmware/node_dl/.

URB_DOWNLINK ?= i2c
NDL_BUILD := build/firmware/node_dl
NDL_DOWNLINKS := i2c can rs485
NDL_STRICT := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
NDL_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
NDL_LIB_COMMON := firmware/node/urb_mailbox.c firmware/node/urb_pll.c firmware/node/urb_node.c firmware/node/urb_observe.c
NDL_SRC_i2c := firmware/node/urb_i2c.c
NDL_SRC_can := firmware/node/urb_node_dl.c firmware/node/urb_node_can.c firmware/downlink/can/urb_can_slave.c \
               firmware/downlink/can/urb_can_transfer.c gen/c/urb_can_wire.c
NDL_SRC_rs485 := firmware/node/urb_node_dl.c firmware/node/urb_node_rs485.c firmware/downlink/rs485/urb_rs485_slave.c \
                 firmware/downlink/rs485/urb_rs485_frame.c
NDL_HDRS := $(wildcard firmware/include/*.h firmware/node/*.h gen/c/*.h tests/firmware/node_dl/*.h tests/firmware/can/*.h \
            firmware/apps/echo/*.h)
NDL_CROSS_CC ?= arm-none-eabi-gcc
NDL_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections
NDL_X := $(NDL_BUILD)/cortex-m0plus

.PHONY: node-lib-downlink size-node-downlinks test-node-downlinks node-dl-tests node-dl-mutants

ifeq ($(filter $(URB_DOWNLINK),$(NDL_DOWNLINKS)),)
$(error URB_DOWNLINK=$(URB_DOWNLINK) is not a downlink: use one of $(NDL_DOWNLINKS))
endif

# --- Cortex-M0+ archives, one per downlink ----------------------------------------------------------
$(NDL_X)/obj/%.o: %.c $(NDL_HDRS)
	@mkdir -p $(@D)
	@$(NDL_CROSS_CC) $(NDL_CROSS_FLAGS) $(NDL_STRICT) -Ifirmware/include -Ifirmware/node -Igen/c -c $< -o $@

ndl_objs = $(patsubst %.c,$(NDL_X)/obj/%.o,$(NDL_LIB_COMMON) $(NDL_SRC_$(1)))
define NDL_LIB_RULE
$(NDL_X)/$(1)/liburb_node.a: $(call ndl_objs,$(1))
	@mkdir -p $$(@D)
	@rm -f $$@ && arm-none-eabi-ar rcs $$@ $$^
endef
$(foreach d,$(NDL_DOWNLINKS),$(eval $(call NDL_LIB_RULE,$(d))))
.PRECIOUS: $(NDL_X)/obj/%.o

node-lib-downlink: $(NDL_X)/$(URB_DOWNLINK)/liburb_node.a
	@echo "node library for the $(URB_DOWNLINK) downlink: $<"

size-node-downlinks: $(foreach d,$(NDL_DOWNLINKS),$(NDL_X)/$(d)/liburb_node.a)
	@$(PYTHON) tests/firmware/node_dl/node_dl_size.py --build $(NDL_X) $(foreach d,$(NDL_DOWNLINKS),--archive $(d)=$(NDL_X)/$(d)/liburb_node.a)

SIZE_TARGETS += size-node-downlinks

# --- the three-downlink test --------------------------------------------------------------------------
NDL_TEST_SRC := tests/firmware/node_dl/topology.c firmware/apps/echo/echo_app.c tests/firmware/can/can_bus.c \
                $(NDL_LIB_COMMON) $(sort $(NDL_SRC_i2c) $(NDL_SRC_can) $(NDL_SRC_rs485)) \
                firmware/downlink/can/urb_can_master.c firmware/downlink/rs485/urb_rs485_master.c \
                firmware/bridge/i2c_master.c gen/c/urb_core.c gen/c/urb_runtime.c gen/c/urb_rs485_wire.c
NDL_INC := -Ifirmware/include -Ifirmware/node -Igen/c -Itests/firmware/can -Itests/firmware/node_dl -Ifirmware/apps/echo
NDL_BRIDGE_SRC := firmware/bridge/bridge.c firmware/bridge/bridge_uplink.c
# seeded bugs: PROGRAM:MUTANT (urb_node_dl.c's for the three-downlink test; the downlink masters' and the
# bridge's for the error flags)
NDL_MUTANTS := three_downlinks:NODE_DL_FRONT_BUFFER three_downlinks:NODE_DL_NO_SYNC three_downlinks:NODE_DL_NO_ID_DONE \
               bridge_flags:CAN_BUSOFF_AS_TIMEOUT bridge_flags:CAN_WAIT_EACH_RECOVERY bridge_flags:RS485_SILENCE_AS_TIMEOUT \
               bridge_flags:RS485_NO_ECHO_CHECK bridge_flags:NO_PROBE
ndl_prog_src = tests/firmware/node_dl/test_$(1).c $(NDL_TEST_SRC) $(if $(filter bridge_flags,$(1)),$(NDL_BRIDGE_SRC))

define NDL_PROG_RULE
$(NDL_BUILD)/%/test_$(1): $(call ndl_prog_src,$(1)) $(NDL_HDRS)
	@mkdir -p $$(@D)
	@$$* $(NDL_STRICT) -D_DEFAULT_SOURCE $(NDL_SAN) $(NDL_INC) -Ifirmware/bridge $(call ndl_prog_src,$(1)) -lcmocka -o $$@
endef
$(foreach p,three_downlinks bridge_flags,$(eval $(call NDL_PROG_RULE,$(p))))
NDL_TEST_BINS := $(foreach cc,gcc clang,$(foreach p,three_downlinks bridge_flags,$(NDL_BUILD)/$(cc)/test_$(p)))

# gcc prints cmocka's report (kept in junit/gcc-*.log), clang writes JUnit XML; both go into the
# evidence record build/evidence/cmocka-node_dl.json (report/urb_report/junit.py)
node-dl-tests: $(NDL_TEST_BINS)
	@mkdir -p $(NDL_BUILD)/junit && rm -f $(NDL_BUILD)/junit/*.xml $(NDL_BUILD)/junit/*.log
	@status=0; xmls=; logs=; for p in three_downlinks bridge_flags; do \
	  CMOCKA_MESSAGE_OUTPUT=stdout $(NDL_BUILD)/gcc/test_$$p > $(NDL_BUILD)/junit/gcc-$$p.log 2>&1 || { status=1; cat $(NDL_BUILD)/junit/gcc-$$p.log; }; \
	  echo "gcc test_$$p: $$(grep -c '^\[       OK \]' $(NDL_BUILD)/junit/gcc-$$p.log) passed"; \
	  CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE=$(NDL_BUILD)/junit/clang-%g.xml $(NDL_BUILD)/clang/test_$$p \
	    > $(NDL_BUILD)/junit/clang-$$p.out 2>&1 || { status=1; cat $(NDL_BUILD)/junit/clang-$$p.out; }; \
	  logs="$$logs --log gcc:test_$$p=$(NDL_BUILD)/junit/gcc-$$p.log"; done; \
	for f in $(NDL_BUILD)/junit/clang-*.xml; do g=$$(basename $$f .xml); xmls="$$xmls --xml clang:test_$${g#clang-}=$$f"; done; \
	$(PYTHON) -m urb_report.junit cmocka --name cmocka-node_dl $$xmls $$logs --rerun "make node-dl-tests" \
	  --tool "gcc=$$(gcc --version | head -1)" --tool "clang=$$(clang --version | head -1)" || status=1; \
	[ $$status -eq 0 ] && echo "node_dl tests: passed with gcc and clang (JUnit: $(NDL_BUILD)/junit/)"; exit $$status

# every seeded bug must make its program fail
node-dl-mutants:
	@mkdir -p $(NDL_BUILD)/mutants
	@for pm in $(NDL_MUTANTS); do p=$${pm%%:*}; m=$${pm#*:}; \
	  src="tests/firmware/node_dl/test_$$p.c $(NDL_TEST_SRC)"; [ $$p = bridge_flags ] && src="$$src $(NDL_BRIDGE_SRC)"; \
	  gcc $(NDL_STRICT) -D_DEFAULT_SOURCE -O0 -DURB_MUTANT_$$m $(NDL_INC) -Ifirmware/bridge $$src -lcmocka \
	      -o $(NDL_BUILD)/mutants/$$m || exit 1; \
	  if CMOCKA_MESSAGE_OUTPUT=stdout timeout 60 $(NDL_BUILD)/mutants/$$m > $(NDL_BUILD)/mutants/$$m.log 2>&1; then \
	    echo "mutant $$m: SURVIVED (test_$$p passes with the seeded bug)"; exit 1; fi; \
	  echo "mutant $$m: caught by test_$$p ($$(grep -m1 'error:\|ERROR: ' $(NDL_BUILD)/mutants/$$m.log | sed 's/.*--- //'))"; done

test-node-downlinks: node-dl-tests
	@$(MAKE) --no-print-directory node-dl-mutants size-node-downlinks

CHECK_TARGETS += test-node-downlinks

# --- hosted nodes (urb-node-hosted): on the CAN hub, or on the RS485 line ------------------------------
#   make node-hosted                      build/firmware/urb-node-hosted: CAN (tools/can_hub.py, urb-bridge-hosted --downlink can)
#   make node-hosted URB_DOWNLINK=rs485   build/firmware/urb-node-hosted-rs485: RS485 (tools/rs485_hub.py, --downlink rs485)
#   URB_MUTANT=NAME builds the seeded bug NAME in too: urb-node-hosted[-rs485]-NAME (tests/host/test_hosted_downlinks.py)
# (URB_DOWNLINK=i2c builds the CAN one: the hosted I2C nodes are the bridge's in-process fakes.)
NDL_NODE_HOSTED_DL := $(if $(filter rs485,$(URB_DOWNLINK)),rs485,can)
NDL_NODE_HOSTED_SRC_can := firmware/hal/hosted/can_hub_client.c $(NDL_SRC_can)
NDL_NODE_HOSTED_SRC_rs485 := firmware/hal/hosted/rs485_hub_client.c $(NDL_SRC_rs485) gen/c/urb_rs485_wire.c
NDL_NODE_HOSTED_DEF_rs485 := -DURB_NODE_HOSTED_RS485
NDL_NODE_HOSTED_SRC := firmware/hal/hosted/node_hosted_main.c firmware/hal/hosted/hub_socket.c firmware/apps/echo/echo_app.c $(NDL_LIB_COMMON) \
                       $(NDL_NODE_HOSTED_SRC_$(NDL_NODE_HOSTED_DL)) gen/c/urb_core.c gen/c/urb_runtime.c
NDL_NODE_HOSTED_INC := -Ifirmware/include -Ifirmware/node -Ifirmware/hal/hosted -Ifirmware/apps/echo -Igen/c
NDL_NODE_HOSTED_BIN := build/firmware/urb-node-hosted$(if $(filter rs485,$(NDL_NODE_HOSTED_DL)),-rs485)$(if $(URB_MUTANT),-$(URB_MUTANT))
$(NDL_NODE_HOSTED_BIN): $(NDL_NODE_HOSTED_SRC) $(NDL_HDRS) $(wildcard firmware/apps/echo/*.h firmware/hal/hosted/*.h)
	@mkdir -p $(@D)
	gcc $(NDL_STRICT) -D_DEFAULT_SOURCE -D_XOPEN_SOURCE=600 -O2 $(NDL_NODE_HOSTED_DEF_$(NDL_NODE_HOSTED_DL)) \
	    $(if $(URB_MUTANT),-DURB_MUTANT_$(URB_MUTANT)) $(NDL_NODE_HOSTED_INC) $(NDL_NODE_HOSTED_SRC) -o $@

.PHONY: node-hosted
node-hosted: $(NDL_NODE_HOSTED_BIN)
