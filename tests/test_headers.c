/* SPDX-License-Identifier: MIT */
/* Header self-sufficiency: compiled once per public header (-DDTH_HEADER=...) under strict C11. */
#include DTH_HEADER
#include DTH_HEADER /* twice: the include guard works */

int dth_header_test_anchor(void);
#if defined(DTH_VERSION_H) && !defined(DTH_STATUS_H)
/* dth/version.h stands alone (generated): it defines the version */
int dth_header_test_anchor(void) { return (int)sizeof DTH_VERSION_STRING + DTH_VERSION_MAJOR; }
#else
int dth_header_test_anchor(void) { return DTH_OK; }
#endif
