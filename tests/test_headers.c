/* SPDX-License-Identifier: MIT */
/* Header self-sufficiency: compiled once per public header (-DDTH_HEADER=...) under strict C11. */
#include DTH_HEADER
#include DTH_HEADER /* twice: the include guard works */

int dth_header_test_anchor(void);
int dth_header_test_anchor(void) { return DTH_OK; }
