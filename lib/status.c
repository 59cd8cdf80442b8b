/* SPDX-License-Identifier: MIT */
/* Status codes: messages and names generated from DTH_STATUS_LIST. */
#include "dth/status.h"

const char *dth_strerror(int status)
{
    switch (status) {
#define DTH__MSG(name, value, msg) case value: return msg;
        DTH_STATUS_LIST(DTH__MSG)
#undef DTH__MSG
    default: return "unknown status";
    }
}

const char *dth_status_name(int status)
{
    switch (status) {
#define DTH__NAME(name, value, msg) case value: return #name;
        DTH_STATUS_LIST(DTH__NAME)
#undef DTH__NAME
    default: return "DTH_UNKNOWN";
    }
}
