/*
 * Bridge firmware tests: runs every group; the exit status is the number of failed tests, so a
 * mutant build (-DURB_MUTANT_...) that some test catches exits non-zero.
 */
#include "support.h"

int main(void)
{
    int failed = 0;
    failed += run_rs232_tests();
    failed += run_fifo_tests();
    failed += run_downlink_tests();
    failed += run_usb_tests();
    failed += run_sync_tests();
    failed += run_discovery_tests();
    failed += run_edges_tests();
    failed += run_mutation_kill_tests();
    failed += run_master_trace_tests();
    failed += run_uplink_model_tests();
    failed += run_usb_model_tests();
    failed += run_fifo_model_tests();
    return failed > 255 ? 255 : failed;
}
