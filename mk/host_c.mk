# The native host library (host/c/README.md). Included by the top-level Makefile; also usable alone
# (`make -f mk/host_c.mk TARGET`), which is how the Python tests of tests/host_c/ build their programs.
HOSTC_BUILD := build/host_c
HOSTC_INC := -Ihost/c/include -Ihost/c/core -Igen/c
HOSTC_CFLAGS := -std=c99 -Wall -Wextra -Werror -pedantic -D_DEFAULT_SOURCE
HOSTC_STRICT := $(HOSTC_CFLAGS) -Wconversion -Wsign-conversion -Wshadow
HOSTC_CORE_SRC := $(sort $(wildcard host/c/core/*.c))
HOSTC_GEN_SRC := gen/c/urb_core.c gen/c/urb_runtime.c gen/c/urb_sensorhex.c
HOSTC_HDRS := $(wildcard host/c/include/*.h host/c/core/*.h gen/c/*.h)

$(HOSTC_BUILD)/libcoreshim.so: tests/host_c/core_shim.c $(HOSTC_CORE_SRC) host/c/port/handover.c host/c/port/serial.c \
                               $(HOSTC_GEN_SRC) $(HOSTC_HDRS)
	@mkdir -p $(@D)
	gcc $(HOSTC_CFLAGS) -g -O1 -fPIC -shared $(HOSTC_INC) $(filter %.c,$^) -o $@

# --- the library -----------------------------------------------------------------------------------
HOSTC_PORT_SRC := $(sort $(wildcard host/c/port/*.c))
HOSTC_LIB_SRC := $(HOSTC_CORE_SRC) $(HOSTC_PORT_SRC) $(HOSTC_GEN_SRC)
HOSTC_OPT := -O2 -g
HOSTC_OBJS := $(patsubst %.c,$(HOSTC_BUILD)/obj/%.o,$(HOSTC_LIB_SRC))
HOSTC_PIC_OBJS := $(patsubst %.c,$(HOSTC_BUILD)/pic/%.o,$(HOSTC_LIB_SRC))

# The library's own sources get the strict warning set; the generated codecs are compiled as gen/c's
# own Makefile fragment compiles them.
$(HOSTC_BUILD)/obj/host/%.o: host/%.c $(HOSTC_HDRS)
	@mkdir -p $(@D)
	gcc $(HOSTC_STRICT) $(HOSTC_OPT) $(HOSTC_INC) -c $< -o $@
$(HOSTC_BUILD)/pic/host/%.o: host/%.c $(HOSTC_HDRS)
	@mkdir -p $(@D)
	gcc $(HOSTC_STRICT) $(HOSTC_OPT) -fPIC $(HOSTC_INC) -c $< -o $@
$(HOSTC_BUILD)/obj/gen/%.o: gen/%.c $(HOSTC_HDRS)
	@mkdir -p $(@D)
	gcc $(HOSTC_CFLAGS) $(HOSTC_OPT) $(HOSTC_INC) -c $< -o $@
$(HOSTC_BUILD)/pic/gen/%.o: gen/%.c $(HOSTC_HDRS)
	@mkdir -p $(@D)
	gcc $(HOSTC_CFLAGS) $(HOSTC_OPT) -fPIC $(HOSTC_INC) -c $< -o $@

$(HOSTC_BUILD)/liburbhost.a: $(HOSTC_OBJS)
	@rm -f $@
	ar rcs $@ $^
$(HOSTC_BUILD)/liburbhost.so: $(HOSTC_PIC_OBJS)
	gcc -shared -Wl,-soname,liburbhost.so $^ -lpthread -o $@

# --- the C++ example (urb.hpp) ------------------------------------------------------------------------
HOSTC_CXXFLAGS := -std=c++17 -Wall -Wextra -Werror -pedantic -fno-exceptions
$(HOSTC_BUILD)/pd_control: host/c/examples/pd_control.cpp host/c/include/urb.hpp $(HOSTC_BUILD)/liburbhost.a
	g++ $(HOSTC_CXXFLAGS) -O2 -g $(HOSTC_INC) $< $(HOSTC_BUILD)/liburbhost.a -lpthread -o $@

.PHONY: host-c-lib
host-c-lib: $(HOSTC_BUILD)/liburbhost.a $(HOSTC_BUILD)/liburbhost.so $(HOSTC_BUILD)/pd_control

# --- cmocka tests under ASan+UBSan, gcc and clang ------------------------------------------------------
# The tests run the library against the real bridge firmware compiled for the host (its hosted rig).
HOSTC_FW_SRC := firmware/bridge/bridge.c firmware/bridge/bridge_uplink.c firmware/bridge/i2c_master.c \
                firmware/hal/hosted/bridge_hosted.c firmware/hal/hosted/bridge_fake_i2c.c
HOSTC_FW_INC := -Ifirmware/include -Ifirmware/hal/hosted -Ifirmware/bridge
HOSTC_TEST_SRC := $(filter-out tests/host_c/core_shim.c tests/host_c/fuzz_%.c,$(wildcard tests/host_c/*.c))
HOSTC_SAN := -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer
HOSTC_TEST_DEPS := $(HOSTC_LIB_SRC) $(HOSTC_FW_SRC) $(HOSTC_TEST_SRC) $(HOSTC_HDRS) $(wildcard tests/host_c/*.h)

define HOSTC_TEST_BINARY
$(HOSTC_BUILD)/$(1)/host-tests: $(HOSTC_TEST_DEPS)
	@mkdir -p $$(@D)
	$(1) $(HOSTC_CFLAGS) $(HOSTC_SAN) $(HOSTC_INC) $(HOSTC_FW_INC) $(HOSTC_MUTANT_FLAGS) $(HOSTC_LIB_SRC) $(HOSTC_FW_SRC) \
	  $(HOSTC_TEST_SRC) -Wl,--wrap=epoll_pwait2 -lcmocka -lutil -lpthread -o $$@
endef
$(eval $(call HOSTC_TEST_BINARY,gcc))
$(eval $(call HOSTC_TEST_BINARY,clang))

$(HOSTC_BUILD)/hpp_check: tests/host_c/hpp_check.cpp host/c/include/urb.hpp $(HOSTC_BUILD)/liburbhost.a
	g++ $(HOSTC_CXXFLAGS) -g -O1 -fsanitize=address,undefined -fno-sanitize-recover=all $(HOSTC_INC) $< \
	  $(HOSTC_BUILD)/liburbhost.a -lpthread -o $@

# --- what make check runs --------------------------------------------------------------------------------
#   make test-host-c      the library and the example (strict warnings), the cmocka tests under ASan+UBSan
#                         with gcc and clang (JUnit: build/host_c/junit/, record build/evidence/cmocka-host_c.json),
#                         every seeded bug of tests/host_c/mutants.json caught, the urb.hpp check program
#   make proofs-hostfuzz  libFuzzer on the RS232 and USB receive paths and their mutants (a part of make proofs)
# The pytest files of tests/host_c/ (the differential test against the Python core, the example and
# header against the hosted bridge over a pty, the hand-over record against handover.py) run in test-py.
PYTHON ?= python3
# 10 s per target after replaying its committed corpus (make check is near its 45-min limit; the
# mutants stop at their first crash): `make proofs-hostfuzz HOSTC_FUZZ_SECONDS=600` for a long session.
HOSTC_FUZZ_SECONDS ?= 10
HOSTC_FUZZ_MUTANT_SECONDS ?= $(or $(FUZZ_MUTANT_SECONDS),60)

.PHONY: test-host-c host-c-tests host-c-mutants proofs-hostfuzz host-c-pytest-deps
host-c-tests: $(HOSTC_BUILD)/gcc/host-tests $(HOSTC_BUILD)/clang/host-tests
	$(PYTHON) tests/host_c/check_host_c.py cmocka $^

host-c-mutants:
	$(PYTHON) tests/host_c/check_host_c.py mutants

test-host-c: host-c-lib $(HOSTC_BUILD)/hpp_check host-c-tests host-c-mutants

proofs-hostfuzz:
	$(PYTHON) tests/host_c/check_host_c.py fuzz --seconds $(HOSTC_FUZZ_SECONDS) --mutant-seconds $(HOSTC_FUZZ_MUTANT_SECONDS)

# Built before the pytest workers start, so that no two of them build one at once.
host-c-pytest-deps: $(HOSTC_BUILD)/libcoreshim.so $(HOSTC_BUILD)/pd_control $(HOSTC_BUILD)/hpp_check
test-py: host-c-pytest-deps

CHECK_TARGETS += test-host-c
PROOF_PARTS += hostfuzz

# --- benchmark: bench/host_cpu_c.py (make bench runs it after bench/host_cpu.py, whose numbers it prints
# side by side; make bench-host-c runs it alone) --------------------------------------------------------
.PHONY: host-c-bench bench-host-c
$(HOSTC_BUILD)/bench/host_cpu_c: bench/host_cpu_c.c $(HOSTC_BUILD)/liburbhost.a
	@mkdir -p $(@D)
	gcc $(HOSTC_CFLAGS) -O2 -g $(HOSTC_INC) $< $(HOSTC_BUILD)/liburbhost.a -lpthread -o $@
$(HOSTC_BUILD)/bench/host_cpu_c_bridges: bench/host_cpu_c_bridges.c $(HOSTC_FW_SRC) $(HOSTC_GEN_SRC)
	@mkdir -p $(@D)
	gcc $(HOSTC_CFLAGS) -O2 $(HOSTC_INC) $(HOSTC_FW_INC) $< $(HOSTC_FW_SRC) $(HOSTC_GEN_SRC) -o $@
host-c-bench: $(HOSTC_BUILD)/bench/host_cpu_c $(HOSTC_BUILD)/bench/host_cpu_c_bridges
bench-host-c: setup bridge-hosted host-c-bench
	$(PYTHON) bench/host_cpu_c.py
