/* A minimal check framework for the host tests: counts checks, prints failures with values. */
#ifndef FS_CHECK_H
#define FS_CHECK_H

#include <stdio.h>

extern int fs_checks_passed;
extern int fs_checks_failed;

#define CHECK(cond)                                                                      \
    do {                                                                                 \
        if (cond) {                                                                      \
            fs_checks_passed++;                                                          \
        } else {                                                                         \
            fs_checks_failed++;                                                          \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);     \
        }                                                                                \
    } while (0)

#define CHECK_EQ(a, b)                                                                   \
    do {                                                                                 \
        long long va_ = (long long)(a), vb_ = (long long)(b);                            \
        if (va_ == vb_) {                                                                \
            fs_checks_passed++;                                                          \
        } else {                                                                         \
            fs_checks_failed++;                                                          \
            fprintf(stderr, "%s:%d: CHECK_EQ failed: %s == %s (%lld != %lld)\n", __FILE__, \
                    __LINE__, #a, #b, va_, vb_);                                         \
        }                                                                                \
    } while (0)

#endif
