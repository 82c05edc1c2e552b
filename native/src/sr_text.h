/* Messages of the native core, the FMI layer and the FMU glue: appending to a fixed buffer and a
 * small printf whose numbers never go through the C library.
 *
 * The C library's printf follows the host's LC_NUMERIC (a host that sets a German locale prints
 * "1,5") and msvcrt prints non-finite values as "1.#INF": every number here is formatted by
 * sr_text_num, the same characters on every platform and in every locale. Every function
 * truncates to the buffer (size n bytes, always NUL-terminated when n > 0) and never writes
 * past it. No global state; thread-safe.
 */
#ifndef SR_TEXT_H
#define SR_TEXT_H

#include <stdarg.h>
#include <stddef.h>

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/** Append the string s (NULL: nothing). */
SR_API void sr_text_cat(char *buf, size_t n, const char *s);

/** buf = s (the previous contents dropped). */
SR_API void sr_text_set(char *buf, size_t n, const char *s);

/** Append the integer v in decimal. */
SR_API void sr_text_int(char *buf, size_t n, long long v);

/** Append x as C's "%.{sig}g" prints it in the "C" locale (sig 1..17): "1.5", "1e-05",
 *  "-0", "nan", "inf", "-inf". */
SR_API void sr_text_num(char *buf, size_t n, double x, int sig);

/** Append x as Python's repr of a float: the shortest digits that give x back ("1.5", "-1.0",
 *  "1e+16", "1e-05", "nan", "inf"). */
SR_API void sr_text_repr(char *buf, size_t n, double x);

/** Append "[a b c]" of v (k values, 4 significant digits, as NumPy's array2string with
 *  precision=4). */
SR_API void sr_text_vec(char *buf, size_t n, const double *v, int k);

/** buf = the format fmt with its arguments, as vsnprintf for the conversions %s, %c, %d, %i,
 *  %u, %ld, %lu, %lld, %llu, %zu, %g, %.<p>g (%e and %f printed as %g) and %% (no width or
 *  flags);
 *  numbers through sr_text_num (%g: 6 significant digits). An unknown conversion is copied
 *  as it stands. Returns the length written. */
SR_API size_t sr_text_vformat(char *buf, size_t n, const char *fmt, va_list ap);
SR_API size_t sr_text_format(char *buf, size_t n, const char *fmt, ...);

#ifdef __cplusplus
}
#endif

#endif /* SR_TEXT_H */
