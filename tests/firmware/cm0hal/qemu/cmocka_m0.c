/* The cmocka subset of cmocka.h (this folder) on QEMU's Cortex-M0, over semihosting. */
#include <setjmp.h>

#include "cmocka.h"
#include "semihost.h"

static jmp_buf qt_env;
static const char *qt_file;
static int qt_line;
static const char *qt_what;

void qt_fail(const char *file, int line, const char *what)
{
    qt_file = file;
    qt_line = line;
    qt_what = what;
    longjmp(qt_env, 1);
}

/* One test with its setup; true when it passed. The setjmp is alone in here so that no variable of
 * the caller lives across the longjmp. */
static bool run_one(const struct CMUnitTest *test)
{
    void *state = NULL;
    if (setjmp(qt_env) != 0) {
        return false;
    }
    if ((test->setup_func != NULL) && (test->setup_func(&state) != 0)) {
        qt_file = "setup";
        qt_line = 0;
        qt_what = "returned non-zero";
        return false;
    }
    test->test_func(&state);
    return true;
}

int qt_run(const char *group, const struct CMUnitTest *tests, size_t count)
{
    uint32_t failed = 0u;
    sh_line_t l;
    sh_clear(&l);
    sh_str(&l, "# ");
    sh_str(&l, group);
    sh_str(&l, " on the Cortex-M0 (QEMU)");
    sh_flush(&l);
    for (size_t i = 0u; i < count; i++) {
        bool const ok = run_one(&tests[i]);
        sh_clear(&l);
        sh_str(&l, ok ? "ok " : "not ok ");
        sh_udec(&l, (uint32_t)(i + 1u));
        sh_str(&l, " - ");
        sh_str(&l, tests[i].name);
        if (!ok) {
            failed++;
            sh_str(&l, ": ");
            sh_str(&l, qt_file);
            sh_str(&l, ":");
            sh_dec(&l, (int32_t)qt_line);
            sh_str(&l, ": ");
            sh_str(&l, qt_what);
        }
        sh_flush(&l);
    }
    sh_clear(&l);
    sh_str(&l, "# ");
    sh_udec(&l, (uint32_t)count);
    sh_str(&l, " checks, ");
    sh_udec(&l, failed);
    sh_str(&l, " failed");
    sh_flush(&l);
    sh_exit(failed == 0u ? 0u : 1u);
}
