/* SR_API: marks the public functions of the native core (exported from the shared library
 * libspacerobot; plain declarations when the sources are compiled into something else, e.g. an
 * FMU binary that exports only the fmi2* functions). */
#ifndef SR_API_H
#define SR_API_H

#if defined(SR_BUILD_LIBRARY)
#  if defined(_WIN32)
#    define SR_API __declspec(dllexport)
#  else
#    define SR_API __attribute__((visibility("default")))
#  endif
#else
#  define SR_API
#endif

#endif /* SR_API_H */
