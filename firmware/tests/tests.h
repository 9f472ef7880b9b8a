/* Host test suites. */
#ifndef FS_TESTS_H
#define FS_TESTS_H
void run_protocol_tests(void);
void run_device_tests(void);
#endif
