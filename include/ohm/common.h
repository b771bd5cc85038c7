/* ohm/common.h — the vocabulary every part of ohm shares, public and
 * internal: status codes and message levels.  Plain C, no dependencies;
 * include <ohm.h> rather than this file. */
#ifndef OHM_COMMON_H
#define OHM_COMMON_H

/* Every call that can fail returns one of these: 0 is success, an error is
 * negative (after libgit2).  The command line maps OHM_ERR_USAGE to exit
 * code 2 and every other error to 1. */
enum {
    OHM_OK = 0,
    OHM_ERR_IO = -1,       /* a file could not be opened, read or written   */
    OHM_ERR_PARSE = -2,    /* a file's contents are malformed               */
    OHM_ERR_INVALID = -3,  /* a value is out of range / inconsistent        */
    OHM_ERR_NOMEM = -4,    /* an allocation failed or would be too large    */
    OHM_ERR_USAGE = -5,    /* bad action, option or value                   */
    OHM_ERR_NUMERIC = -6,  /* singular matrix, residual too large, NaN      */
    OHM_ERR_INTERNAL = -7, /* a library threw, or a bug                     */
    OHM_ERR_CANCELLED = -8 /* ohm_context_cancel (or Ctrl-C) stopped the call */
};

/* The level of a message handed to a log callback. */
enum { OHM_LOG_WARNING = 1, OHM_LOG_INFO = 2 };

#endif
