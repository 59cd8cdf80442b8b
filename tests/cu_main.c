/* SPDX-License-Identifier: MIT */
/*
 * Shared CUnit main. argv[1], if given, runs one suite by name. Exit code for meson: 0 pass,
 * 1 fail (including a failed suite init: CUnit's own error code would report a pass), 99 when
 * the registry cannot be set up. Never a raw failure count.
 */
#include <stdio.h>
#include <stdlib.h>
#include <CUnit/Basic.h>
#include "cu_main.h"

int main(int argc, char **argv)
{
    if (CU_initialize_registry() != CUE_SUCCESS) return 99;
    if (CU_register_suites(dth_test_suites) != CUE_SUCCESS) {
        fprintf(stderr, "cannot register suites: %s\n", CU_get_error_msg());
        CU_cleanup_registry();
        return 99;
    }
    CU_basic_set_mode(CU_BRM_VERBOSE);
    CU_ErrorCode run_rc;
    if (argc > 1) {
        CU_pSuite s = CU_get_suite(argv[1]);
        if (!s) {
            fprintf(stderr, "no suite named '%s'\n", argv[1]);
            CU_cleanup_registry();
            return 99;
        }
        run_rc = CU_basic_run_suite(s);
    } else {
        run_rc = CU_basic_run_tests();
    }
    unsigned failures = CU_get_number_of_failure_records();
    unsigned asserts = CU_get_number_of_asserts(), failed = CU_get_number_of_failures();
    printf("\n%u passed, %u failed\n", asserts - failed, failed);
    int rc = (failures || run_rc != CUE_SUCCESS) ? EXIT_FAILURE : EXIT_SUCCESS;
    CU_cleanup_registry();
    return rc;
}
