/*
 * REQUIRE for the libFuzzer targets: a property the code under test promises was broken, so the
 * run stops with a crash libFuzzer reports and keeps as a reproducer.
 */
#ifndef FUZZ_REQUIRE_H
#define FUZZ_REQUIRE_H

#include <stdlib.h>

#define REQUIRE(cond)     \
    do {                  \
        if (!(cond)) {    \
            abort();      \
        }                 \
    } while (0)

#endif /* FUZZ_REQUIRE_H */
