/* A portable seeded random generator: the same seed gives the same numbers on every platform
 * and compiler.
 *
 * - Bits: xoshiro256** 1.0 (Blackman and Vigna, "Scrambled linear pseudorandom number
 *   generators", ACM TOMS 2021; https://prng.di.unimi.it/xoshiro256starstar.c), seeded from one
 *   64-bit integer by splitmix64 (https://prng.di.unimi.it/splitmix64.c), as its authors
 *   recommend. Independent streams: sr_rng_jump (2^128 outputs apart).
 * - Uniform doubles in [0, 1): the 53 high bits times 2^-53 (exact).
 * - Standard normals: Marsaglia's polar method (two normals per accepted pair; the second is
 *   kept in the generator for the next call). It needs sqrt (exactly rounded by IEEE 754 on
 *   every platform) and a logarithm: the C library's log is not guaranteed identical across C
 *   libraries, so sr_ln (sr_math.h) computes it with +, -, *, / only (below 1 ulp from the true
 *   value). With IEEE 754 doubles and no contraction into FMA (-ffp-contract=off, as
 *   native/build.py compiles) every result is then the same bits everywhere.
 * - sr_portable_sincos: sine and cosine by the same rules.
 *
 * A generator is a plain struct (no pointers): copy it to save or restore its state.
 * No global state; thread-safe per generator.
 */
#ifndef SR_RNG_H
#define SR_RNG_H

#include <stdint.h>

#include "sr_api.h"

#ifdef __cplusplus
extern "C" {
#endif

/** The state of one generator (40 bytes of state + the kept normal; no padding). */
typedef struct sr_rng {
    uint64_t s[4];        /* xoshiro256** state, never all zero */
    double spare;         /* the second normal of the last accepted pair, if has_spare */
    int32_t has_spare;    /* 1: spare is the next normal */
    int32_t reserved;     /* 0 */
} sr_rng;

/** splitmix64: advance *x by the golden-ratio increment and return its mix (the reference
 *  splitmix64.c next()). */
SR_API uint64_t sr_splitmix64(uint64_t *x);

/** Seed g from an integer: s[0..3] = four successive splitmix64 outputs of state seed;
 *  no normal kept. Every seed gives a valid (non-zero) state. */
SR_API void sr_rng_seed(sr_rng *g, uint64_t seed);

/** Set g's xoshiro256** state directly (s (4); an all-zero state is replaced by the seed-0
 *  state, since xoshiro would then output zeros for ever); no normal kept. */
SR_API void sr_rng_set_state(sr_rng *g, const uint64_t *s);

/** The next 64 random bits (xoshiro256** next()). */
SR_API uint64_t sr_rng_next(sr_rng *g);

/** Advance g by 2^128 outputs (xoshiro256** jump()): sr_rng_jump applied k times to a
 *  generator gives k non-overlapping streams. Drops a kept normal. */
SR_API void sr_rng_jump(sr_rng *g);

/** Advance g by 2^192 outputs (xoshiro256** long_jump()): 2^64 starting points for
 *  sr_rng_jump streams. Drops a kept normal. */
SR_API void sr_rng_long_jump(sr_rng *g);

/** A uniform double in [0, 1): (next >> 11) * 2^-53. */
SR_API double sr_rng_uniform(sr_rng *g);

/** A standard normal variate (Marsaglia's polar method over sr_rng_uniform, with
 *  sr_portable_log): u, v = 2 U - 1, s = u^2 + v^2, rejected unless 0 < s < 1; returns
 *  u sqrt(-2 log s / s) and keeps v sqrt(-2 log s / s) for the next call. */
SR_API double sr_rng_normal(sr_rng *g);

/** out[i] = sr_rng_uniform(g), i < n (out (n); nothing for n <= 0). */
SR_API void sr_rng_uniforms(sr_rng *g, int n, double *out);

/** out[i] = sr_rng_normal(g), i < n (out (n); nothing for n <= 0). */
SR_API void sr_rng_normals(sr_rng *g, int n, double *out);

/** Natural logarithm: sr_ln of sr_math.h (+, -, *, / only: the same bits on every IEEE 754
 *  platform; below 1 ulp). x > 0 finite
 *  (subnormals included); log(+0) = -inf, log(+inf) = +inf, NaN for x < 0 or NaN. */
SR_API double sr_portable_log(double x);

/** Sine and cosine of x [rad]: sr_sincos of sr_math.h (+, -, *, / and floor only: the same
 *  bits on every IEEE 754 platform). Correctly
 *  rounded for |x| < 1.6e6 (deterministic, less accurate beyond); NaN for
 *  non-finite x or |x| >= 1e15. s or c may be NULL. */
SR_API void sr_portable_sincos(double x, double *s, double *c);

#ifdef __cplusplus
}
#endif

#endif /* SR_RNG_H */
