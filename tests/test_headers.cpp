/* SPDX-License-Identifier: MIT */
/* Header C++ compatibility: compiled once per public header (-DDTH_HEADER=...) as C++11. */
#include DTH_HEADER
#include DTH_HEADER /* twice: the include guard works */

int dth_header_test_anchor();
int dth_header_test_anchor() { return DTH_OK; }
