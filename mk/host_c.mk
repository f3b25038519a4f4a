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
