/* Portable seeded random generator (see rng.h): xoshiro256**, splitmix64 seeding, polar-method
 * normals with the portable logarithm of sr_math.c (the same bits on every IEEE 754 platform). */
#include "rng.h"

#include <math.h>
#include <string.h>

#include "sr_math.h"

uint64_t sr_splitmix64(uint64_t *x)
{
    uint64_t z = (*x += UINT64_C(0x9e3779b97f4a7c15));
    z = (z ^ (z >> 30)) * UINT64_C(0xbf58476d1ce4e5b9);
    z = (z ^ (z >> 27)) * UINT64_C(0x94d049bb133111eb);
    return z ^ (z >> 31);
}

void sr_rng_seed(sr_rng *g, uint64_t seed)
{
    uint64_t x = seed;
    int i;
    for (i = 0; i < 4; ++i)
        g->s[i] = sr_splitmix64(&x);
    /* four successive splitmix64 outputs are never all zero (its mix is a bijection of
     * distinct counters), so the state is valid */
    g->spare = 0.0;
    g->has_spare = 0;
    g->reserved = 0;
}

void sr_rng_set_state(sr_rng *g, const uint64_t *s)
{
    if ((s[0] | s[1] | s[2] | s[3]) == 0) {
        sr_rng_seed(g, 0);
        return;
    }
    memcpy(g->s, s, sizeof g->s);
    g->spare = 0.0;
    g->has_spare = 0;
    g->reserved = 0;
}

static uint64_t rotl(uint64_t x, int k)
{
    return (x << k) | (x >> (64 - k));
}

uint64_t sr_rng_next(sr_rng *g)
{
    uint64_t *s = g->s;
    const uint64_t result = rotl(s[1] * 5, 7) * 9;
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0];
    s[3] ^= s[1];
    s[1] ^= s[2];
    s[0] ^= s[3];
    s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return result;
}

/* the reference jump: the state times a fixed polynomial in the engine's transition */
static void jump(sr_rng *g, const uint64_t JUMP[4])
{
    uint64_t t[4] = {0, 0, 0, 0};
    int i, b;
    for (i = 0; i < 4; ++i)
        for (b = 0; b < 64; ++b) {
            if (JUMP[i] & (UINT64_C(1) << b)) {
                t[0] ^= g->s[0];
                t[1] ^= g->s[1];
                t[2] ^= g->s[2];
                t[3] ^= g->s[3];
            }
            sr_rng_next(g);
        }
    memcpy(g->s, t, sizeof t);
    g->spare = 0.0;
    g->has_spare = 0;
}

void sr_rng_jump(sr_rng *g)
{
    static const uint64_t J[4] = {UINT64_C(0x180ec6d33cfd0aba), UINT64_C(0xd5a61266f0c9392c),
                                  UINT64_C(0xa9582618e03fc9aa), UINT64_C(0x39abdc4529b1661c)};
    jump(g, J);
}

void sr_rng_long_jump(sr_rng *g)
{
    static const uint64_t J[4] = {UINT64_C(0x76e15d3efefdcbbf), UINT64_C(0xc5004e441c522fb3),
                                  UINT64_C(0x77710069854ee241), UINT64_C(0x39109bb02acbe635)};
    jump(g, J);
}

double sr_rng_uniform(sr_rng *g)
{
    return (double)(sr_rng_next(g) >> 11) * 0x1.0p-53;
}

double sr_rng_normal(sr_rng *g)
{
    double u, v, s, f;
    if (g->has_spare) {
        g->has_spare = 0;
        return g->spare;
    }
    do {
        u = 2.0 * sr_rng_uniform(g) - 1.0;
        v = 2.0 * sr_rng_uniform(g) - 1.0;
        s = u * u + v * v;
    } while (!(s < 1.0 && s > 0.0));
    f = sqrt(-2.0 * sr_ln(s) / s);
    g->spare = v * f;
    g->has_spare = 1;
    return u * f;
}

void sr_rng_uniforms(sr_rng *g, int n, double *out)
{
    int i;
    for (i = 0; i < n; ++i)
        out[i] = sr_rng_uniform(g);
}

void sr_rng_normals(sr_rng *g, int n, double *out)
{
    int i;
    for (i = 0; i < n; ++i)
        out[i] = sr_rng_normal(g);
}

/* -- portable elementary functions (sr_math.c; kept here for rng.h's callers) ------------------ */

double sr_portable_log(double x)
{
    return sr_ln(x);
}

void sr_portable_sincos(double x, double *s, double *c)
{
    sr_sincos(x, s, c);
}
