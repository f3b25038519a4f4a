/*
 * The few cmocka calls the tests of tests/firmware/cm0hal use, for running those same test files on a
 * Cortex-M0 under QEMU (make cm0hal-qemu), where cmocka is not built: each check that fails prints a
 * "not ok" line with its place and ends the test (longjmp), the run prints "ok"/"not ok" per test and
 * "# N checks, M failed", and its status is QEMU's exit status (tests/qemu/run.sh reads both).
 * Found before the real <cmocka.h> by the include order of the qemu build only.
 */
#ifndef CM0HAL_QEMU_CMOCKA_H
#define CM0HAL_QEMU_CMOCKA_H

#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef void (*CMUnitTestFunction)(void **state);
typedef int (*CMFixtureFunction)(void **state);

struct CMUnitTest {
    const char *name;
    CMUnitTestFunction test_func;
    CMFixtureFunction setup_func;
};

/** Ends the running test as failed: `what` at file:line. */
void qt_fail(const char *file, int line, const char *what) __attribute__((noreturn));
/** Runs the tests and ends the emulation (status 0: all passed, 1: one failed). */
int qt_run(const char *group, const struct CMUnitTest *tests, size_t count) __attribute__((noreturn));

#define cmocka_unit_test_setup(f, setup) {#f, f, setup}
#define cmocka_run_group_tests_name(group, tests, setup, teardown) \
    qt_run(group, tests, sizeof(tests) / sizeof((tests)[0]))

#define QT_CHECK(cond, what) \
    do { \
        if (!(cond)) { \
            qt_fail(__FILE__, __LINE__, what); \
        } \
    } while (0)
#define assert_true(c) QT_CHECK((c), #c)
#define assert_false(c) QT_CHECK(!(c), "!(" #c ")")
#define assert_int_equal(a, b) QT_CHECK((uint64_t)(a) == (uint64_t)(b), #a " == " #b)
#define assert_int_not_equal(a, b) QT_CHECK((uint64_t)(a) != (uint64_t)(b), #a " != " #b)
#define assert_memory_equal(a, b, n) QT_CHECK(memcmp((a), (b), (n)) == 0, "memory " #a " == " #b)
#define assert_null(p) QT_CHECK((p) == NULL, #p " == NULL")
#define assert_non_null(p) QT_CHECK((p) != NULL, #p " != NULL")

#endif /* CM0HAL_QEMU_CMOCKA_H */
