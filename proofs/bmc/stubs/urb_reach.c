/*
 * urb_reach.c: the vacuity check of a proof harness (make reach, URB_VERIFY_REACH; see urb_verify.h).
 *
 * The harness's own assertions are off; this entry point runs it and then asserts false. ESBMC must
 * report VERIFICATION FAILED on "reach: ...": some input satisfies every assumption of the harness
 * and of the code under proof, within the unwinding bound, and reaches the end. VERIFICATION
 * SUCCESSFUL means the assumptions contradict each other (or every path is cut): the proof's
 * assertions were never checked on any input. The harness's cover points (URB_COVER) are
 * assertions of urb_cover_off in the same run, each solved on its own (--multi-property).
 */
#include "urb_verify.h"

void harness(void);
void urb_reach(void);

/* The cover points' assertion (URB_COVER in urb_verify.h): false, read from a variable. */
bool urb_cover_off = false;

void urb_reach(void)
{
    harness();
    URB_ASSERT_(false, "reach: the harness runs to its end on some input");
}
