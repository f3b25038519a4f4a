# CAN and RS485 downlinks (firmware/downlink/, issue #39 phase 1). Included by the top-level Makefile.
#   make test-downlinks     cmocka tests of both downlinks with gcc and clang under ASan+UBSan, then the
#                           mutant check (every seeded URB_MUTANT_CAN_* / URB_MUTANT_RS485_* bug must make
#                           its test program fail), then the Cortex-M0+ build of every core
#   make size-downlinks     flash/RAM of the CAN and RS485 cores on Cortex-M0+ (part of `make size`)
# Outputs go to build/firmware/downlinks/.

FWD_BUILD := build/firmware/downlinks
FWD_STRICT := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
FWD_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
FWD_TEST_CFLAGS := -std=c99 -Wall -Wextra -Werror -D_DEFAULT_SOURCE
FWD_INC := -Ifirmware/include -Igen/c -Itests/firmware/can -Itests/firmware/dl_common
FWD_CAN_SRC := firmware/downlink/can/urb_can_transfer.c firmware/downlink/can/urb_can_master.c \
               firmware/downlink/can/urb_can_slave.c
FWD_RS485_SRC := firmware/downlink/rs485/urb_rs485_frame.c firmware/downlink/rs485/urb_rs485_master.c \
                 firmware/downlink/rs485/urb_rs485_slave.c
FWD_CAN_TEST := tests/firmware/can/test_can.c tests/firmware/can/can_bus.c tests/firmware/dl_common/fake_mailbox.c \
                gen/c/urb_core.c gen/c/urb_can_wire.c gen/c/urb_runtime.c
FWD_RS485_TEST := tests/firmware/rs485/test_rs485.c tests/firmware/dl_common/fake_mailbox.c \
                  gen/c/urb_core.c gen/c/urb_rs485_wire.c gen/c/urb_runtime.c
FWD_HDRS := $(wildcard firmware/include/urb_can*.h firmware/include/urb_rs485*.h firmware/include/urb_dl_slave.h \
              firmware/include/urb_downlink.h gen/c/*.h tests/firmware/can/*.h tests/firmware/dl_common/*.h)
FWD_CAN_MUTANTS := CAN_NO_TOGGLE_CHECK CAN_CRC_LITTLE_ENDIAN CAN_START_TOGGLE_0 CAN_NO_TID_FILTER \
                   CAN_BUSOFF_AS_TIMEOUT CAN_SAME_TID CAN_NO_DEDUP CAN_COMMIT_BAD_CRC CAN_KEEP_READ_ON_NEW
FWD_RS485_MUTANTS := RS485_NO_GAP_BREAK RS485_NO_LENGTH_LIMIT RS485_EARLY_END RS485_NO_ECHO_CHECK \
                     RS485_SEND_WHILE_BUSY RS485_SILENCE_AS_TIMEOUT RS485_COMMIT_BAD_CHECK RS485_ANSWER_OTHERS \
                     RS485_PROBE_WRITES RS485_KEEP_CUT_READ
FWD_CROSS_CC ?= arm-none-eabi-gcc
FWD_CROSS_SIZE ?= arm-none-eabi-size
FWD_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -ffunction-sections -fdata-sections

.PHONY: test-downlinks downlinks-tests downlinks-mutants cross-downlinks size-downlinks

# --- cmocka tests under sanitizers: one program per downlink and compiler ------------------------
# $(1) compiler, $(2) can|rs485, $(3) firmware sources, $(4) test sources. The firmware sources are
# first checked alone with the strict warnings (no code generated, so no sanitizer or coverage flags:
# with --coverage gcc would write a notes file per source into the working directory).
define FWD_TEST_RULE
$(FWD_BUILD)/$(1)/test_$(2): $(3) $(4) $(FWD_HDRS)
	@mkdir -p $$(@D)
	@for f in $(3); do $(1) $(FWD_STRICT) $(FWD_INC) -fsyntax-only $$$$f || exit 1; done
	$(1) $(FWD_TEST_CFLAGS) $(FWD_SAN) $(FWD_INC) $(3) $(4) -lcmocka -o $$@
endef
$(foreach cc,gcc clang,$(eval $(call FWD_TEST_RULE,$(cc),can,$(FWD_CAN_SRC),$(FWD_CAN_TEST))))
$(foreach cc,gcc clang,$(eval $(call FWD_TEST_RULE,$(cc),rs485,$(FWD_RS485_SRC),$(FWD_RS485_TEST))))

FWD_TEST_BINS := $(foreach cc,gcc clang,$(FWD_BUILD)/$(cc)/test_can $(FWD_BUILD)/$(cc)/test_rs485)

downlinks-tests: $(FWD_TEST_BINS)
	@for t in $(FWD_TEST_BINS); do CMOCKA_MESSAGE_OUTPUT=stdout $$t > $$t.log 2>&1 || { cat $$t.log; exit 1; }; \
	  echo "$$t: $$(grep -c '^\[       OK \]' $$t.log) passed, 0 failed"; done
	@mkdir -p $(FWD_BUILD)/junit && rm -f $(FWD_BUILD)/junit/*.xml
	@CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE=$(FWD_BUILD)/junit/%g.xml $(FWD_BUILD)/gcc/test_can >/dev/null
	@CMOCKA_MESSAGE_OUTPUT=xml CMOCKA_XML_FILE=$(FWD_BUILD)/junit/%g.xml $(FWD_BUILD)/gcc/test_rs485 >/dev/null

# --- mutants: each seeded bug must make its test program fail ------------------------------------
$(FWD_BUILD)/mutants/%/test_can: $(FWD_CAN_SRC) $(FWD_CAN_TEST) $(FWD_HDRS)
	@mkdir -p $(@D)
	@gcc $(FWD_TEST_CFLAGS) -O0 -DURB_MUTANT_$* $(FWD_INC) $(FWD_CAN_SRC) $(FWD_CAN_TEST) -lcmocka -o $@
$(FWD_BUILD)/mutants/%/test_rs485: $(FWD_RS485_SRC) $(FWD_RS485_TEST) $(FWD_HDRS)
	@mkdir -p $(@D)
	@gcc $(FWD_TEST_CFLAGS) -O0 -DURB_MUTANT_$* $(FWD_INC) $(FWD_RS485_SRC) $(FWD_RS485_TEST) -lcmocka -o $@

define FWD_MUTANT_RULE
$(FWD_BUILD)/mutants/$(1).caught: $(FWD_BUILD)/mutants/$(1)/test_$(2)
	@if CMOCKA_MESSAGE_OUTPUT=stdout timeout 120 $$< > $(FWD_BUILD)/mutants/$(1).log 2>&1; then \
	  echo "mutant $(1): SURVIVED (the tests pass with the seeded bug)"; exit 1; \
	else echo "mutant $(1): caught by $$$$(grep '^\[  FAILED  \] test_' $(FWD_BUILD)/mutants/$(1).log | sort -u | wc -l) test(s)"; touch $$@; fi
endef
$(foreach m,$(FWD_CAN_MUTANTS),$(eval $(call FWD_MUTANT_RULE,$(m),can)))
$(foreach m,$(FWD_RS485_MUTANTS),$(eval $(call FWD_MUTANT_RULE,$(m),rs485)))
.PRECIOUS: $(FWD_BUILD)/mutants/%/test_can $(FWD_BUILD)/mutants/%/test_rs485

downlinks-mutants:
	@rm -f $(FWD_BUILD)/mutants/*.caught
	@$(MAKE) --no-print-directory $(patsubst %,$(FWD_BUILD)/mutants/%.caught,$(FWD_CAN_MUTANTS) $(FWD_RS485_MUTANTS))
	@echo "downlink mutants: all $(words $(FWD_CAN_MUTANTS) $(FWD_RS485_MUTANTS)) caught"

# --- Cortex-M0+ --------------------------------------------------------------------------------------
$(FWD_BUILD)/cortex-m0plus/%.o: %.c $(FWD_HDRS)
	@mkdir -p $(@D)
	@$(FWD_CROSS_CC) $(FWD_CROSS_FLAGS) $(FWD_STRICT) -Ifirmware/include -Igen/c -c $< -o $@

FWD_X_OBJS := $(patsubst %.c,$(FWD_BUILD)/cortex-m0plus/%.o,$(FWD_CAN_SRC) $(FWD_RS485_SRC) gen/c/urb_can_wire.c \
                gen/c/urb_rs485_wire.c tests/firmware/downlink_size_probe.c)

cross-downlinks: $(FWD_X_OBJS)
	@echo "cross-downlinks: the CAN and RS485 cores build for Cortex-M0+ with $(FWD_STRICT)"

size-downlinks: cross-downlinks
	@$(PYTHON) tests/firmware/downlink_size.py --size $(FWD_CROSS_SIZE) --build $(FWD_BUILD)/cortex-m0plus

SIZE_TARGETS += size-downlinks

test-downlinks: downlinks-tests
	@$(MAKE) --no-print-directory downlinks-mutants cross-downlinks

CHECK_TARGETS += test-downlinks
