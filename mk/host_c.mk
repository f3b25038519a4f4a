# The native host library (host/c/README.md). Included by the top-level Makefile; also usable alone
# (`make -f mk/host_c.mk TARGET`), which is how the Python tests of tests/host_c/ build their programs.
HOSTC_BUILD := build/host_c
HOSTC_INC := -Ihost/c/include -Ihost/c/core -Igen/c
HOSTC_CFLAGS := -std=c99 -Wall -Wextra -Werror -pedantic -D_DEFAULT_SOURCE
HOSTC_STRICT := $(HOSTC_CFLAGS) -Wconversion -Wsign-conversion -Wshadow
HOSTC_CORE_SRC := $(sort $(wildcard host/c/core/*.c))
HOSTC_GEN_SRC := gen/c/urb_core.c gen/c/urb_runtime.c gen/c/urb_sensorhex.c
HOSTC_HDRS := $(wildcard host/c/include/*.h host/c/core/*.h gen/c/*.h)

$(HOSTC_BUILD)/libcoreshim.so: tests/host_c/core_shim.c $(HOSTC_CORE_SRC) $(HOSTC_GEN_SRC) $(HOSTC_HDRS)
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
	  $(HOSTC_TEST_SRC) -lcmocka -lutil -lpthread -o $$@
endef
$(eval $(call HOSTC_TEST_BINARY,gcc))
$(eval $(call HOSTC_TEST_BINARY,clang))
