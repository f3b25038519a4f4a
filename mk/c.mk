# C codecs (gen/c). Included by the top-level Makefile (`include mk/*.mk`).
#   make test-c    build tests/c/codec_driver.c and tests/c/unit_tests.c with gcc and clang under
#                  ASan+UBSan (into build/c/) and run tests/test_c_codecs.py against them
#   make cross-c   compile every gen/c/*.c for Cortex-M0+ with the strict warning set and print sizes
PYTEST ?= tools/run-pytest

CODEC_GEN := gen/c
CODEC_BUILD := build/c
CODEC_WARNINGS := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
CODEC_CROSS_CC ?= arm-none-eabi-gcc
CODEC_CROSS_SIZE ?= arm-none-eabi-size
CODEC_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os
CODEC_CROSS_OBJS := $(patsubst $(CODEC_GEN)/%.c,$(CODEC_BUILD)/cortex-m0plus/%.o,$(wildcard $(CODEC_GEN)/*.c))

.PHONY: test-c cross-c
test-c:
	$(PYTEST) -q tests/test_c_codecs.py

cross-c: $(CODEC_CROSS_OBJS)
	$(CODEC_CROSS_SIZE) -t $^

$(CODEC_BUILD)/cortex-m0plus/%.o: $(CODEC_GEN)/%.c $(wildcard $(CODEC_GEN)/*.h)
	@mkdir -p $(@D)
	$(CODEC_CROSS_CC) $(CODEC_CROSS_FLAGS) $(CODEC_WARNINGS) -I$(CODEC_GEN) -c $< -o $@

CHECK_TARGETS += test-c cross-c
