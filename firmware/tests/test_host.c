/* Host test runner: framing and device logic, compiled with the host gcc (ASan + UBSan). */
#include <stdio.h>

#include "check.h"
#include "tests.h"

int fs_checks_passed = 0;
int fs_checks_failed = 0;

int main(void)
{
    run_protocol_tests();
    run_device_tests();
    printf("%d passed, %d failed\n", fs_checks_passed, fs_checks_failed);
    return fs_checks_failed == 0 ? 0 : 1;
}
