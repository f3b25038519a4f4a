/* The host library's cmocka tests: every group; the exit status counts the failed tests. */
#include "host_test.h"

int main(void)
{
    int failed = 0;
    failed += run_core_tests();
    failed += run_usb_tests();
    failed += run_discovery_tests();
    failed += run_port_tests();
    failed += run_loop_wait_tests();
    return failed;
}
