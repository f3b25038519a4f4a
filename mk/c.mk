# C codecs (gen/c). Included by the top-level Makefile (`include mk/*.mk`); also usable alone
# (`make -f mk/c.mk ...`), which is how tests/test_c_codecs.py builds its programs.
#   make test-c    run tests/test_c_codecs.py: codec_driver and unit_tests built with gcc and clang
#                  under ASan+UBSan (build/c/<program>-<compiler>), vectors, differential fuzzing
#                  against the Python codecs, capacity and canary checks
#   make cross-c   compile every gen/c/*.c for Cortex-M0+ with the strict warning set; print sizes
PYTEST ?= tools/run-pytest
PYTHON ?= python3

CODEC_GEN := gen/c
CODEC_BUILD := build/c
CODEC_WARNINGS := -std=c99 -Wall -Wextra -Wconversion -Wsign-conversion -Wpedantic -Werror
CODEC_SANITIZE := -g -O1 -fno-omit-frame-pointer -fsanitize=address,undefined -fno-sanitize-recover=all
CODEC_SOURCES := $(wildcard $(CODEC_GEN)/*.c)
CODEC_HEADERS := $(wildcard $(CODEC_GEN)/*.h $(CODEC_GEN)/test/*.h)
CODEC_CROSS_CC ?= arm-none-eabi-gcc
CODEC_CROSS_SIZE ?= arm-none-eabi-size
CODEC_CROSS_FLAGS := -mcpu=cortex-m0plus -mthumb -Os
CODEC_CROSS_OBJS := $(patsubst $(CODEC_GEN)/%.c,$(CODEC_BUILD)/cortex-m0plus/%.o,$(CODEC_SOURCES))

.PHONY: test-c cross-c
# Its JUnit XML becomes the evidence record build/evidence/pytest-c.json (report/urb_report/junit.py).
PYTEST_SEED ?= 0
test-c:
	@rm -f build/evidence/pytest-c.json build/junit/pytest-c.xml
	$(PYTEST) -q tests/test_c_codecs.py --hypothesis-seed=$(PYTEST_SEED) --junitxml=build/junit/pytest-c.xml \
	  -o junit_family=xunit1; status=$$?; \
	$(PYTHON) -m urb_report.junit pytest build/junit/pytest-c.xml --name pytest-c --seed $(PYTEST_SEED) \
	  --args "pytest -q tests/test_c_codecs.py --hypothesis-seed=$(PYTEST_SEED)" || status=1; exit $$status

cross-c: $(CODEC_CROSS_OBJS)
	$(CODEC_CROSS_SIZE) -t $^

$(CODEC_BUILD)/cortex-m0plus/%.o: $(CODEC_GEN)/%.c $(CODEC_HEADERS)
	@mkdir -p $(@D)
	$(CODEC_CROSS_CC) $(CODEC_CROSS_FLAGS) $(CODEC_WARNINGS) -I$(CODEC_GEN) -c $< -o $@

# Sanitizer builds for tests, one per compiler: build/c/codec_driver-gcc, build/c/unit_tests-clang, ...
$(CODEC_BUILD)/codec_driver-%: tests/c/codec_driver.c tests/c/codec_error_name.h $(CODEC_GEN)/test/urb_test_support.c $(CODEC_SOURCES) $(CODEC_HEADERS)
	@mkdir -p $(@D)
	$* $(CODEC_WARNINGS) -Wshadow $(CODEC_SANITIZE) -I$(CODEC_GEN) -I$(CODEC_GEN)/test $(filter %.c,$^) -o $@

$(CODEC_BUILD)/unit_tests-%: tests/c/unit_tests.c $(CODEC_GEN)/test/urb_test_support.c $(CODEC_SOURCES) $(CODEC_HEADERS)
	@mkdir -p $(@D)
	$* $(CODEC_WARNINGS) -Wshadow $(CODEC_SANITIZE) -I$(CODEC_GEN) -I$(CODEC_GEN)/test $(filter %.c,$^) -o $@

CHECK_TARGETS += test-c cross-c
