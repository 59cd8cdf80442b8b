/* SPDX-License-Identifier: MIT */
/* Shared CUnit main for every test executable: one suite table per file, exit codes meson reads. */
#ifndef DTH_CU_MAIN_H
#define DTH_CU_MAIN_H

#include <CUnit/CUnit.h>

/** Each test file defines its suites (terminated by CU_SUITE_INFO_NULL). */
extern CU_SuiteInfo dth_test_suites[];

/* Helpers for assertions with a message. */
#define DTH_ASSERT_LE(a, b) CU_ASSERT((a) <= (b))

#endif
