/* SPDX-License-Identifier: MIT */
/** @file status.h  Status codes shared by every dth function, and their messages. */
#ifndef DTH_STATUS_H
#define DTH_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

#if defined(DTH_BUILDING) && !defined(DTH_STATIC)
#define DTH_API __attribute__((visibility("default")))
#else
#define DTH_API
#endif

/**
 * One list of status codes. 0 is success. Positive codes are recoverable conditions of a
 * step (the state is untouched; the caller may change h, regularize, or stop). Negative codes
 * are hard errors (bad arguments, memory, LAPACK misuse, model failure).
 */
#define DTH_STATUS_LIST(X)                                                                      \
    X(DTH_OK, 0, "success")                                                                     \
    X(DTH_ENOCONV, 1, "Newton iteration for the step did not converge")                         \
    X(DTH_ESINGULAR, 2, "the bordered step Jacobian is singular")                               \
    X(DTH_ENOROOT, 3, "no root of the step constraint in the direction of travel")             \
    X(DTH_ENEGOFFSET, 4, "no physical root: H/psi < 0 at the vertex (trajectory ends here)")   \
    X(DTH_EGHOST, 5, "only a ghost root lies ahead (psi changes sign)")                         \
    X(DTH_EFOLD, 6, "the physical root merges with the ghost root (fold)")                      \
    X(DTH_EDOMAIN, 7, "the model returned NaN or Inf, or left its domain")                      \
    X(DTH_EREFUSED, 8, "the regularizer refused to carry the trajectory on")                    \
    X(DTH_ESTEPSIZE, 9, "the step size left the allowed range")                                 \
    X(DTH_ESTOPPED, 10, "the run was stopped by the caller (a callback of the run driver)")      \
    X(DTH_EACCURACY, 11, "the estimated error outgrew the run's bound (the steps are too large)") \
    X(DTH_EINVAL, -1, "invalid argument")                                                       \
    X(DTH_ENOMEM, -2, "out of memory")                                                          \
    X(DTH_ELAPACK, -3, "LAPACK reported an illegal argument")                                   \
    X(DTH_EMODEL, -4, "a model callback reported an error")                                     \
    X(DTH_EIO, -5, "input/output error")                                                        \
    X(DTH_EPARSE, -6, "parse error")                                                            \
    X(DTH_ENOTFOUND, -7, "not found")                                                           \
    X(DTH_EUNSUPPORTED, -8, "operation not supported by this model or method")

/** Status code. */
typedef enum dth_status {
#define DTH__ENUM(name, value, msg) name = value,
    DTH_STATUS_LIST(DTH__ENUM)
#undef DTH__ENUM
} dth_status;

/** Fixed English message for a status code (never NULL; unknown codes get a generic text). */
DTH_API const char *dth_strerror(int status);

/** Symbolic name of a status code, e.g. "DTH_ENOCONV" (never NULL). */
DTH_API const char *dth_status_name(int status);

#ifdef __cplusplus
}
#endif
#endif
