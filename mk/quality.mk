# Structural coverage, MISRA C:2012 and static analysis of the firmware and the generated C
# (quality/README.md says how to read the results). Included by the top-level Makefile.
#   make coverage  the node, bridge, codec, CAN/RS485 downlink and Cortex-M0+ CAN/RS485 port tests on two instrumented
#                  builds: gcc --coverage
#                  (statement and branch, gcovr) and clang 19 -fcoverage-mcdc (MC/DC, llvm-cov);
#                  every uncovered line, branch or MC/DC condition must be justified in
#                  quality/coverage_justifications.toml. Reports: build/coverage/ (gcc/index.html,
#                  clang/index.html, summary.md); record: build/evidence/coverage.json
#   make misra     cppcheck's MISRA C:2012 addon; every finding needs a deviation in
#                  quality/misra_deviations.toml. build/misra/, build/evidence/misra.json
#   make static    clang-tidy (clang-analyzer-*, bugprone-*, cert-*) and gcc -fanalyzer; every
#                  finding needs a deviation in quality/static_deviations.toml.
#                  build/static/, build/evidence/static.json
# Each target fails on an unjustified finding and on a stale justification (one that no longer
# matches anything), so the files stay exact.
#
# The coverage builds reuse the test programs' own rules and source lists (mk/firmware_node.mk,
# mk/firmware_bridge.mk, mk/c.mk, mk/downlinks.mk, mk/node_downlinks_cm0.mk) through sub-makes that override their build directory, compiler
# and flags: the instrumented programs are the tested programs. This file therefore sorts after
# those fragments (`include $(wildcard mk/*.mk)` reads them in name order) and uses their variables.
PYTHON ?= python3

ifndef FWB_TEST_BINARY
$(error mk/quality.mk needs mk/firmware_bridge.mk, mk/firmware_node.mk and mk/c.mk read first)
endif
ifndef CM0HAL_RULE
$(error mk/quality.mk needs mk/node_downlinks_cm0.mk read first)
endif
ifndef FWD_TEST_RULE
$(error mk/quality.mk needs mk/downlinks.mk read first)
endif

# ===== Coverage =================================================================================

COV_BUILD := build/coverage
COV_CLANG := clang-19
COV_LLVM_SUFFIX := -19
# -O0: every statement and condition keeps its own code, so counts map to the source one to one.
COV_GCC_FLAGS := -O0 -g --coverage
COV_CLANG_FLAGS := -O0 -g -fprofile-instr-generate -fcoverage-mapping -fcoverage-mcdc
# The strict warning set without -Werror: clang 19 warns (with no -W flag to select it) about each
# decision it cannot measure for MC/DC; tools/coverage.py collects those warnings and reports them.
COV_WARN := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic
COV_TEST_WARN := -std=c99 -Wall -Wextra -D_DEFAULT_SOURCE

# The bridge fragment instantiates its test program for gcc and clang; the MC/DC build needs clang-19.
$(eval $(call FWB_TEST_BINARY,$(COV_CLANG)))
# The Cortex-M0+ CAN and RS485 ports' host tests (mk/node_downlinks_cm0.mk), likewise.
COV_CM0HAL_TESTS := test_cm0_can test_cm0_rs485
$(foreach t,$(COV_CM0HAL_TESTS),$(eval $(call CM0HAL_RULE,$(COV_CLANG),$(t))))
# The CAN and RS485 downlink cores' cmocka programs (mk/downlinks.mk), likewise.
COV_DL_TESTS := test_can test_rs485
$(eval $(call FWD_TEST_RULE,$(COV_CLANG),can,$(FWD_CAN_SRC),$(FWD_CAN_TEST)))
$(eval $(call FWD_TEST_RULE,$(COV_CLANG),rs485,$(FWD_RS485_SRC),$(FWD_RS485_TEST)))

# $(1): build directory name (gcc, clang), $(2): compiler, $(3): instrumentation flags
cov_build = \
	$(MAKE) --no-print-directory FWN_BUILD=$(COV_BUILD)/$(1)/node FWN_COMPILERS=$(2) FWN_WARN="$(COV_WARN)" \
	    FWN_SAN="$(3)" $(foreach t,$(FWN_TESTS),$(COV_BUILD)/$(1)/node/$(2)/$(t)) && \
	$(MAKE) --no-print-directory FWB_BUILD=$(COV_BUILD)/$(1)/bridge FWB_STRICT="$(COV_WARN)" \
	    FWB_TEST_CFLAGS="$(COV_TEST_WARN)" FWB_SAN="$(3)" $(COV_BUILD)/$(1)/bridge/$(2)/bridge-tests && \
	$(MAKE) --no-print-directory CODEC_BUILD=$(COV_BUILD)/$(1)/c CODEC_WARNINGS="$(COV_WARN)" CODEC_SANITIZE="$(3)" \
	    $(COV_BUILD)/$(1)/c/codec_driver-$(2) $(COV_BUILD)/$(1)/c/unit_tests-$(2) && \
	$(MAKE) --no-print-directory CM0DL_BUILD=$(COV_BUILD)/$(1)/cm0hal CM0DL_STRICT="$(COV_WARN)" CM0HAL_SAN="$(3)" \
	    $(foreach t,$(COV_CM0HAL_TESTS),$(COV_BUILD)/$(1)/cm0hal/$(2)/$(t)) && \
	$(MAKE) --no-print-directory FWD_BUILD=$(COV_BUILD)/$(1)/downlinks FWD_STRICT="$(COV_WARN)" \
	    FWD_TEST_CFLAGS="$(COV_TEST_WARN)" FWD_SAN="$(3)" $(foreach t,$(COV_DL_TESTS),$(COV_BUILD)/$(1)/downlinks/$(2)/$(t))

cov_programs = $(foreach t,$(FWN_TESTS),$(COV_BUILD)/$(1)/node/$(2)/$(t)) $(COV_BUILD)/$(1)/bridge/$(2)/bridge-tests \
               $(foreach t,$(COV_CM0HAL_TESTS),$(COV_BUILD)/$(1)/cm0hal/$(2)/$(t)) \
               $(foreach t,$(COV_DL_TESTS),$(COV_BUILD)/$(1)/downlinks/$(2)/$(t))
cov_codecs = $(COV_BUILD)/$(1)/c/codec_driver-$(2) $(COV_BUILD)/$(1)/c/unit_tests-$(2)

.PHONY: coverage coverage-build misra static

coverage-build:
	@$(call cov_build,gcc,gcc,$(COV_GCC_FLAGS))
	@$(call cov_build,clang,$(COV_CLANG),$(COV_CLANG_FLAGS))

# The cmocka programs run directly; the codec programs under tests/test_c_codecs.py (its random and
# mutated frames are most of the codecs' coverage).
coverage: setup coverage-build
	$(PYTHON) tools/coverage.py --build $(COV_BUILD) \
	    --run "$(call cov_programs,gcc,gcc) $(call cov_programs,clang,$(COV_CLANG))" \
	    --llvm-objects "$(call cov_programs,clang,$(COV_CLANG)) $(call cov_codecs,clang,$(COV_CLANG))" \
	    --codec-programs $(COV_BUILD)/gcc/c:$(COV_BUILD)/clang/c --codec-compilers "gcc $(COV_CLANG)" --fuzz-replay \
	    --clang $(COV_CLANG) --llvm-suffix=$(COV_LLVM_SUFFIX) \
	    --gcc-flags="$(COV_GCC_FLAGS)" --clang-flags="$(COV_CLANG_FLAGS)" \
	    --clang-cflags="$(COV_WARN) $(FWN_INC) -Ifirmware/bridge -DURB_NODE_TESTING"

# ===== MISRA C:2012 and static analysis =========================================================

# What ships: the node and bridge libraries, the CAN and RS485 downlink cores (FWD_CAN_SRC,
# FWD_RS485_SRC of mk/downlinks.mk), the SensoRHex apps and their target mains and board stubs, the
# Cortex-M0+ port and startup code, and the generated codecs. Not the hosted and simulation HALs or
# the hosted bridge's main (test doubles that run on a PC with its C library and are never linked
# into a firmware image), nor gen/c/test (test support that uses stdio).
QUALITY_SOURCES := $(sort $(wildcard firmware/node/*.c) $(FWB_LIB_SRC) $(FWD_CAN_SRC) $(FWD_RS485_SRC) \
                   $(wildcard firmware/apps/sensorhex/*.c) \
                   $(wildcard firmware/apps/sensorhex/targets/*.c) $(wildcard firmware/hal/cortex-m0plus/*.c) \
                   $(wildcard gen/c/*.c))
QUALITY_INC := -Ifirmware/include -Ifirmware/node -Ifirmware/bridge -Ifirmware/hal/cortex-m0plus -Ifirmware/apps/echo \
               -Ifirmware/apps/sensorhex -Ifirmware/apps/sensorhex/targets -Igen/c
# The target's configuration (arm-none-eabi-gcc 12 predefines __GNUC__ and __arm__); the motor app
# stands for SENSORHEX_APP in targets/main_node.c, which every app image compiles the same way.
QUALITY_DEFS := -D__GNUC__=12 -D__arm__=1 -DSENSORHEX_APP=motor -DSENSORHEX_APP_STORAGE=SENSORHEX_MOTOR_STORAGE

misra: setup
	$(PYTHON) tools/misra.py --sources "$(QUALITY_SOURCES)" \
	    --cppcheck-args "--std=c99 --platform=arm32-wchar_t4 --suppress=missingIncludeSystem -j2 $(QUALITY_DEFS) $(QUALITY_INC)"

# clang-tidy parses for the target with newlib's headers; gcc -fanalyzer is the images' compiler at -Os.
STATIC_TIDY_FLAGS := --target=armv6m-none-eabi -mthumb -std=c99 -isystem /usr/lib/arm-none-eabi/include \
                     $(QUALITY_DEFS) $(QUALITY_INC)
STATIC_GCC_FLAGS := -mcpu=cortex-m0plus -mthumb -Os -std=c99 -DSENSORHEX_APP=motor \
                    -DSENSORHEX_APP_STORAGE=SENSORHEX_MOTOR_STORAGE $(QUALITY_INC)

static: setup
	$(PYTHON) tools/static_analysis.py --sources "$(QUALITY_SOURCES)" --tidy clang-tidy-19 \
	    --tidy-cflags "$(STATIC_TIDY_FLAGS)" --gcc $(FWN_CROSS_CC) --gcc-cflags "$(STATIC_GCC_FLAGS)"

CHECK_TARGETS += coverage misra static
