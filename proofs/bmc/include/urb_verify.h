/*
 * urb_verify.h: the one vocabulary every URB proof harness uses, mapped onto each tool's builtins.
 *
 * Select the tool with exactly one macro (proofs/bmc/Makefile.common passes it):
 *   URB_VERIFY_ESBMC   ESBMC: __ESBMC_assume / __ESBMC_assert, nondet via __VERIFIER_nondet_*
 *   URB_VERIFY_CBMC    CBMC:  __CPROVER_assume / __CPROVER_assert, nondet via nondet_*
 *   URB_VERIFY_NATIVE  a plain compiler: nondet values come from urb_native_next() (a replay or
 *                      random driver, proofs/bmc/stubs/native_driver.c); a failed assumption
 *                      abandons the run; a failed assertion prints and aborts.
 *
 * Harnesses use ONLY these macros, never a tool builtin: ESBMC treats an unknown function such as
 * __CPROVER_assume as returning an arbitrary value, so a harness written for CBMC would silently
 * prove nothing under ESBMC.
 *
 *   URB_ASSUME(c)            restrict the inputs to those satisfying c
 *   URB_ASSERT(c, "name")    property to prove for every input
 *   URB_NONDET_U8() ...      an arbitrary value of the type (U8 U16 U32 U64 I8 I16 I32 SIZE BOOL)
 *   URB_NONDET_BYTES(a, n)   arbitrary contents for the uninitialised local byte array a[0 .. n-1]
 *   URB_TIGHT(c, "name")     a witness that c is reachable: a no-op in a proof run; when
 *                            URB_VERIFY_TIGHT is defined it becomes an assertion of !(c), which
 *                            the tool must then REFUTE (tools/proofs.py runs it, expects a failure)
 *   URB_COVER("name")        a cover point: this statement must be reachable. A no-op in a proof
 *                            run; in the reach run (URB_VERIFY_REACH) the assertion "cover: name"
 *                            of false, which the tool must REFUTE (some input gets here). Write
 *                            `if (c) { URB_COVER("name"); }` to cover a condition. The name is the
 *                            evidence id (bmc-cover:<folder>/<name>): letters, digits, - _ . only.
 *   URB_COVER_FULL("name")   the same, checked only in the full tier (URB_TIER_FAST undefined): for
 *                            a cover point too costly for the fast tier or reached only by a
 *                            full-tier item
 *
 * Vacuity check (make reach): with URB_VERIFY_REACH defined every URB_ASSERT is off and
 * proofs/bmc/stubs/urb_reach.c calls harness() then asserts false ("reach: ..."), which the tool
 * must REFUTE: some input satisfies every URB_ASSUME and the harness runs to its end, so the
 * proof's assertions are not vacuously true.
 *   URB_COST_BEGIN()         clears the cost counter before the call under proof
 *   URB_COST_END(budget)     asserts the call's cost fits the budget and the recorded worst case
 *
 * Cost counter (bounded latency). Sources under proof are instrumented by
 * proofs/bmc/prepare.py: every function entry and every loop iteration executes
 * URB_COST(cycles), with cycles from proofs/bmc/cost_model.json. With URB_PROOF_COST defined the
 * counter is the global urb_proof_cost; otherwise URB_COST expands to nothing (production code
 * never sees it: the instrumented copies live under build/ only). Macros that change a run:
 *   URB_COST_BOUND=n   the recorded worst case (the folder's COST file): asserted, and witnessed
 *                      in tight runs
 *   URB_COST_PROBE=n   probe run: every property but "cost <= n" is off (worst-case search)
 */
#ifndef URB_VERIFY_H
#define URB_VERIFY_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#if (defined(URB_VERIFY_ESBMC) + defined(URB_VERIFY_CBMC) + defined(URB_VERIFY_NATIVE)) != 1
#error "define exactly one of URB_VERIFY_ESBMC, URB_VERIFY_CBMC, URB_VERIFY_NATIVE"
#endif

/* ===== Tool mapping ======================================================================= */

#if defined(URB_VERIFY_ESBMC)

/* ESBMC declares __ESBMC_assume, __ESBMC_assert and the __VERIFIER_nondet_* family itself
 * (esbmc_intrinsics.h); declaring them again with other types is an error. */

#define URB_ASSUME(c) __ESBMC_assume((_Bool)(c))
#define URB_ASSERT_(c, name) __ESBMC_assert((_Bool)(c), name)
#define URB_NONDET_U8() ((uint8_t)__VERIFIER_nondet_uchar())
#define URB_NONDET_U16() ((uint16_t)__VERIFIER_nondet_ushort())
#define URB_NONDET_U32() ((uint32_t)__VERIFIER_nondet_uint())
#define URB_NONDET_U64() ((uint64_t)__VERIFIER_nondet_ulonglong())
#define URB_NONDET_I8() ((int8_t)__VERIFIER_nondet_char())
#define URB_NONDET_I16() ((int16_t)__VERIFIER_nondet_short())
#define URB_NONDET_I32() ((int32_t)__VERIFIER_nondet_int())
#define URB_NONDET_SIZE() ((size_t)__VERIFIER_nondet_ulong())
#define URB_NONDET_BOOL() ((bool)__VERIFIER_nondet_bool())
/* An uninitialised local is already arbitrary; filling it byte by byte would only hide constants
 * from ESBMC's constant propagation (a struct written in a loop loses its other known members). */
#define URB_NONDET_BYTES(array, size) ((void)0)

#elif defined(URB_VERIFY_CBMC)

unsigned char nondet_uchar(void);
unsigned short nondet_ushort(void);
unsigned int nondet_uint(void);
unsigned long long nondet_ulonglong(void);
signed char nondet_schar(void);
short nondet_short(void);
int nondet_int(void);
unsigned long nondet_ulong(void);
_Bool nondet_bool(void);

#define URB_ASSUME(c) __CPROVER_assume(c)
#define URB_ASSERT_(c, name) __CPROVER_assert((c), name)
#define URB_NONDET_U8() ((uint8_t)nondet_uchar())
#define URB_NONDET_U16() ((uint16_t)nondet_ushort())
#define URB_NONDET_U32() ((uint32_t)nondet_uint())
#define URB_NONDET_U64() ((uint64_t)nondet_ulonglong())
#define URB_NONDET_I8() ((int8_t)nondet_schar())
#define URB_NONDET_I16() ((int16_t)nondet_short())
#define URB_NONDET_I32() ((int32_t)nondet_int())
#define URB_NONDET_SIZE() ((size_t)nondet_ulong())
#define URB_NONDET_BOOL() ((bool)nondet_bool())
#define URB_NONDET_BYTES(array, size) ((void)0) /* uninitialised locals are arbitrary */

#else /* URB_VERIFY_NATIVE */

/** Next arbitrary value, from the driver (proofs/bmc/stubs/native_driver.c). */
uint64_t urb_native_next(void);
/** Abandons the current run: an assumption does not hold for these values. */
void urb_native_reject(void);
/** Reports a failed property and aborts. */
void urb_native_fail(const char *name, const char *file, int line);

#define URB_ASSUME(c) do { if (!(c)) { urb_native_reject(); } } while (0)
#define URB_ASSERT_(c, name) do { if (!(c)) { urb_native_fail(name, __FILE__, __LINE__); } } while (0)
#define URB_NONDET_U8() ((uint8_t)urb_native_next())
#define URB_NONDET_U16() ((uint16_t)urb_native_next())
#define URB_NONDET_U32() ((uint32_t)urb_native_next())
#define URB_NONDET_U64() ((uint64_t)urb_native_next())
#define URB_NONDET_I8() ((int8_t)(uint8_t)urb_native_next())
#define URB_NONDET_I16() ((int16_t)(uint16_t)urb_native_next())
#define URB_NONDET_I32() ((int32_t)(uint32_t)urb_native_next())
#define URB_NONDET_SIZE() ((size_t)urb_native_next())
#define URB_NONDET_BOOL() ((urb_native_next() & 1u) != 0u)
/** Fills a local byte array (uninitialised locals are arbitrary for the checkers, not for cc). */
void urb_native_fill(void *array, size_t size);
#define URB_NONDET_BYTES(array, size) urb_native_fill((array), (size))

#endif

/* ===== Properties ======================================================================== */

#if defined(URB_COST_PROBE) || (defined(URB_VERIFY_REACH) && !defined(URB_COVER_OFF))
/* A probe run (make probe) asks one question, the largest cost, and a cover run (make reach)
 * whether the harness ends at all and which cover points it reaches, so every other property is off.
 * The condition is still evaluated: harnesses call the code under proof inside assertions
 * (`URB_ASSERT(release() == URB_NODE_OK, ...)`), and a run without those calls would be another
 * program than the proof's (the reach run of fw_mailbox_outbox never set its outbox up, which its
 * first cover points showed). */
#define URB_ASSERT(c, name) ((void)(c))
#elif defined(URB_VERIFY_REACH)
/* The plain vacuity check (make reach COVERS=0, the one make check runs): the harness's end
 * reachable, its assertions left out whole, calls inside them too. It is the cheap check (a cover
 * run costs up to 30 times more); the cover run checks the program as proved. */
#define URB_ASSERT(c, name) ((void)0)
#else
#define URB_ASSERT(c, name) URB_ASSERT_(c, name)
#endif

#if defined(URB_VERIFY_TIGHT)
#define URB_TIGHT(c, name) URB_ASSERT_(!(c), "tight: " name)
#else
#define URB_TIGHT(c, name) ((void)0)
#endif

/* Cover points (proofs/README.md, Cover points): tools/proofs.py lists the points compiled into a
 * run from the preprocessed harness, runs every one as its own property (--multi-property) and
 * fails the proof naming each point that no run of its part reaches. */
#if defined(URB_VERIFY_REACH) && !defined(URB_COVER_OFF) && !defined(URB_VERIFY_NATIVE)
/* False, but not a constant: ESBMC 8.4 drops every statement after an assertion of the literal
 * false from the program (so a second cover point right behind a first one would vanish and never
 * be reported reached); stubs/urb_reach.c defines it. */
extern bool urb_cover_off;
#define URB_COVER(name) URB_ASSERT_(urb_cover_off, "cover: " name)
#else
#define URB_COVER(name) ((void)0)
#endif
#if defined(URB_TIER_FAST)
#define URB_COVER_FULL(name) ((void)0)
#else
#define URB_COVER_FULL(name) URB_COVER(name)
#endif

/* ===== Cost counter ======================================================================= */

#if defined(URB_PROOF_COST)
/** Cycles spent since the harness last cleared it (Cortex-M0+ model, proofs/bmc/cost_model.json). */
extern uint32_t urb_proof_cost;
/** The cost of the last measured call; counterexamples of probe runs show it. */
extern uint32_t urb_proof_cost_seen;
#define URB_COST(cycles) ((void)(urb_proof_cost += (uint32_t)(cycles)))
/** Defines the counters; exactly one translation unit (the harness) uses it, at file scope. */
#define URB_PROOF_COST_STORAGE uint32_t urb_proof_cost = 0u; uint32_t urb_proof_cost_seen = 0u
#else
#define URB_COST(cycles) ((void)0)
#define URB_PROOF_COST_STORAGE extern int urb_proof_cost_unused_
#endif

/** Starts measuring: clears the counter before the call under proof. */
#define URB_COST_BEGIN() ((void)(urb_proof_cost = 0u))

#if defined(URB_COST_BOUND)
#define URB_COST_BOUND_CHECK_(c)                                                                   \
    do {                                                                                           \
        URB_ASSERT((c) <= URB_COST_BOUND, "cost: within the recorded worst case (COST)");          \
        URB_TIGHT((c) == URB_COST_BOUND, "cost: the recorded worst case is reached");              \
    } while (0)
#else
#define URB_COST_BOUND_CHECK_(c) ((void)0)
#endif

#if defined(URB_COST_PROBE)
#define URB_COST_PROBE_CHECK_(c) URB_ASSERT_((c) <= URB_COST_PROBE, "cost probe")
#else
#define URB_COST_PROBE_CHECK_(c) ((void)0)
#endif

/**
 * Ends measuring: the cost of the call must fit `budget` (cycles derived from bus timing) and the
 * recorded worst case COST_BOUND; a tight run shows COST_BOUND is reached, a probe run bounds it.
 */
#define URB_COST_END(budget)                                                                       \
    do {                                                                                           \
        urb_proof_cost_seen = urb_proof_cost;                                                      \
        URB_ASSERT(urb_proof_cost_seen <= (uint32_t)(budget), "cost: within the bus budget");     \
        URB_COST_BOUND_CHECK_(urb_proof_cost_seen);                                                \
        URB_COST_PROBE_CHECK_(urb_proof_cost_seen);                                                \
    } while (0)

#endif /* URB_VERIFY_H */
