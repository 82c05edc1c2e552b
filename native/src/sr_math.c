/* Portable elementary functions (see sr_math.h): +, -, *, /, sqrt, floor, fmod and bit
 * manipulation only, so every IEEE 754 platform gives the same bits. Constants are hexadecimal
 * floating literals (exact). sr_ln is the algorithm rng.c used for its normals (unchanged:
 * the same bits as before); sr_sincos replaces rng.c's single-double Taylor sine and cosine
 * (within 2 ulp) by a correctly rounded double-double one (a table-driven fast path that
 * returns only what the double-double series would, ~3x faster). */
#include "sr_math.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

static double from_bits(uint64_t b)
{
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

static uint64_t to_bits(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

/* -- exact products (Dekker / Veltkamp, no FMA) ---------------------------------------------- */

/* a = hi + lo with hi of 26 significant bits (|a| < 2^995: the product below must not overflow) */
static void split(double a, double *hi, double *lo)
{
    const double c = 134217729.0 * a;       /* 2^27 + 1 */
    *hi = c - (c - a);
    *lo = a - *hi;
}

/* p + e = a b exactly (p = fl(a b); no underflow in the partial products) */
static void two_prod(double a, double b, double *p, double *e)
{
    double ah, al, bh, bl;
    *p = a * b;
    split(a, &ah, &al);
    split(b, &bh, &bl);
    *e = ((ah * bh - *p) + ah * bl + al * bh) + al * bl;
}

/* s + e = a + b exactly, |a| >= |b| */
static void fast_two_sum(double a, double b, double *s, double *e)
{
    *s = a + b;
    *e = b - (*s - a);
}

/* s + e = a + b exactly */
static void two_sum(double a, double b, double *s, double *e)
{
    const double t = a + b, v = t - a;
    *e = (a - (t - v)) + (b - v);
    *s = t;
}

/* (h, l) = (ah + al) (bh + bl) in double-double (relative error ~2^-102) */
static void dd_mul(double ah, double al, double bh, double bl, double *h, double *l)
{
    double p, e;
    two_prod(ah, bh, &p, &e);
    e += ah * bl + al * bh;
    fast_two_sum(p, e, h, l);
}

/* (h, l) = (ah + al) + (bh + bl) in double-double */
static void dd_add(double ah, double al, double bh, double bl, double *h, double *l)
{
    double t, e;
    two_sum(ah, bh, &t, &e);
    e += al + bl;
    fast_two_sum(t, e, h, l);
}

/* x 2^e with one rounding (x normal, |x| in [1, 4)); +-inf or +-0 beyond the range */
static double scale2(double x, long long e)
{
    if (e > 2100)
        e = 2100;
    if (e < -2200)
        e = -2200;
    while (e > 1023) {
        x *= 0x1.0p+1023;
        e -= 1023;
    }
    while (e < -1022) {                     /* exact until the last step (x stays normal) */
        x *= 0x1.0p-1022;
        e += 1022;
    }
    return x * from_bits((uint64_t)(e + 1023) << 52);
}

/* -- hypot ------------------------------------------------------------------------------------ */

double sr_hypot(double x, double y)
{
    double ax, ay;
    if (!(fabs(x) <= 0x1.fffffffffffffp+1023) || !(fabs(y) <= 0x1.fffffffffffffp+1023)) {
        if (fabs(x) > 0x1.fffffffffffffp+1023 || fabs(y) > 0x1.fffffffffffffp+1023)
            return HUGE_VAL;                /* inf wins over NaN (C99 F.9.4.3) */
        return x + y;                       /* NaN */
    }
    ax = fabs(x);
    ay = fabs(y);
    if (ax < ay) {
        const double t = ax;
        ax = ay;
        ay = t;
    }
    /* scaled by 2^-+600 (exact) where a square would overflow or underflow */
    if (ax > 0x1.0p+511) {
        if (ay <= ax * 0x1.0p-54)           /* ay^2 below half an ulp of ax^2 */
            return ax + ay;
        return sr_hypot_kernel(ax * 0x1.0p-600, ay * 0x1.0p-600) * 0x1.0p+600;
    }
    if (ay < 0x1.0p-459) {
        if (ax >= ay * 0x1.0p+54)           /* also ay = 0 */
            return ax + ay;
        return sr_hypot_kernel(ax * 0x1.0p+600, ay * 0x1.0p+600) * 0x1.0p-600;
    }
    if (ay <= ax * 0x1.0p-54)
        return ax + ay;
    return sr_hypot_kernel(ax, ay);
}

/* -- sine and cosine -------------------------------------------------------------------------- */

/* 1/k! in double-double (hi correctly rounded, lo = 1/k! - hi rounded) */
static const double INV_FACT[24][2] = {
    {0x1.0000000000000p+0, 0.0}, {0x1.0000000000000p+0, 0.0},
    {0x1.0000000000000p-1, 0.0}, {0x1.5555555555555p-3, 0x1.5555555555555p-57},
    {0x1.5555555555555p-5, 0x1.5555555555555p-59}, {0x1.1111111111111p-7, 0x1.1111111111111p-63},
    {0x1.6c16c16c16c17p-10, -0x1.f49f49f49f49fp-65}, {0x1.a01a01a01a01ap-13, 0x1.a01a01a01a01ap-73},
    {0x1.a01a01a01a01ap-16, 0x1.a01a01a01a01ap-76}, {0x1.71de3a556c734p-19, -0x1.c154f8ddc6c00p-73},
    {0x1.27e4fb7789f5cp-22, 0x1.cbbc05b4fa99ap-76}, {0x1.ae64567f544e4p-26, -0x1.c062e06d1f209p-80},
    {0x1.1eed8eff8d898p-29, -0x1.2aec959e14c06p-83}, {0x1.6124613a86d09p-33, 0x1.f28e0cc748ebep-87},
    {0x1.93974a8c07c9dp-37, 0x1.05d6f8a2efd1fp-92}, {0x1.ae7f3e733b81fp-41, 0x1.1d8656b0ee8cbp-97},
    {0x1.ae7f3e733b81fp-45, 0x1.1d8656b0ee8cbp-101}, {0x1.952c77030ad4ap-49, 0x1.ac981465ddc6cp-103},
    {0x1.6827863b97d97p-53, 0x1.eec01221a8b0bp-107}, {0x1.2f49b46814157p-57, 0x1.2650f61dbdcb4p-112},
    {0x1.e542ba4020225p-62, 0x1.ea72b4afe3c2fp-120}, {0x1.71b8ef6dcf572p-66, -0x1.d043ae40c4647p-120},
    {0x1.0ce396db7f853p-70, -0x1.aebcdbd20331cp-124}, {0x1.761b41316381ap-75, -0x1.3423c7d91404fp-130}};

/* sum_j (-1)^j z^j / (2j + odd)!, j = 0..11, for z = zh + zl <= (pi/4)^2 + a little: the terms
 * j >= 4 (below 4e-7 of the sum) in double, the rest by double-double Horner steps */
static void series(double zh, double zl, int odd, double *h, double *l)
{
    double a = 0.0, ah, al;
    int j;
    for (j = 11; j >= 4; --j)
        a = a * zh + ((j & 1) ? -INV_FACT[2 * j + odd][0] : INV_FACT[2 * j + odd][0]);
    ah = a;
    al = 0.0;
    for (j = 3; j >= 0; --j) {
        const double ch = INV_FACT[2 * j + odd][0], cl = INV_FACT[2 * j + odd][1];
        dd_mul(ah, al, zh, zl, &ah, &al);
        if (j & 1)
            dd_add(ah, al, -ch, -cl, &ah, &al);
        else
            dd_add(ah, al, ch, cl, &ah, &al);
    }
    *h = ah;
    *l = al;
}

/* sin and cos of a/128, a = 0..103, in double-double: {sin hi, sin lo, cos hi, cos lo}, hi
 * correctly rounded, lo = the rest rounded (computed with 300-bit arithmetic, mpmath) */
static const double SINCOS_TAB[104][4] = {
    {0.0, 0.0, 0x1.0000000000000p+0, 0.0},
    {0x1.fffeaaaaeeeefp-8, -0x1.e45e2ec67b77cp-62, 0x1.fffc000155552p-1, 0x1.f4a01a0196daep-55},
    {0x1.fffaaaaeeeed5p-7, -0x1.2ab639a9f0776p-63, 0x1.fff000155549fp-1, 0x1.28a28a03a5ef3p-55},
    {0x1.7ff7001033255p-6, 0x1.efe2b51527336p-64, 0x1.ffdc006bff7e6p-1, 0x1.ae6dae86977bdp-55},
    {0x1.ffeaaaeeee86fp-6, -0x1.cd406fb224ae2p-60, 0x1.ffc00155527d3p-1, -0x1.3b54492d89b5bp-55},
    {0x1.3feb2b12d45d5p-5, 0x1.4ec54203d1c11p-60, 0x1.ff9c03414a7bap-1, 0x1.991f4be6c59bfp-57},
    {0x1.7fdc01032fba9p-5, -0x1.599bdf46e997ap-59, 0x1.ff7006bfdf99fp-1, -0x1.8b3b560648d5fp-56},
    {0x1.bfc6d78586dacp-5, 0x1.8e4fd03dbf236p-62, 0x1.ff3c0c8103a31p-1, 0x1.4856dbddc0e66p-56},
    {0x1.ffaaaeeed4edbp-5, -0x1.2d16d32684b69p-59, 0x1.ff0015549f4d3p-1, 0x1.328387b99426fp-55},
    {0x1.1fc343d808befp-4, -0x1.f3d32e6f3be4fp-58, 0x1.febc222a8ef9fp-1, 0x1.7934934f54c77p-58},
    {0x1.3facb12d1755bp-4, -0x1.921915299468bp-58, 0x1.fe7034129ef6fp-1, -0x1.cbf4337c96f97p-57},
    {0x1.5f911fd10b737p-4, -0x1.0184f02be9102p-58, 0x1.fe1c4c3c873ebp-1, -0x1.5a9c9057c4a02p-60},
    {0x1.7f701032550e4p-4, 0x1.afc2d1800501ap-60, 0x1.fdc06bf7e6b9bp-1, 0x1.31902b535f8dbp-55},
    {0x1.9f4902d55d1f9p-4, 0x1.2696d7eac1dc1p-58, 0x1.fd5c94b43e000p-1, -0x1.2e768cb4f92f9p-57},
    {0x1.bf1b78568391dp-4, 0x1.e91841dea4cc8p-58, 0x1.fcf0c800e99b1p-1, 0x1.ea3d786d186acp-57},
    {0x1.dee6f16c1cce6p-4, -0x1.50f8e2fb71673p-59, 0x1.fc7d078d1bc88p-1, 0x1.075d2447db685p-55},
    {0x1.feaaeee86ee36p-4, -0x1.afcb2bcc6f03bp-59, 0x1.fc015527d5bd3p-1, 0x1.b68f35094efb8p-55},
    {0x1.0f3378ddd71d1p-3, 0x1.d8468724f0f9ep-57, 0x1.fb7db2bfe0695p-1, 0x1.21dadf4f65ab1p-55},
    {0x1.1f0d3d7afceafp-3, -0x1.6ef95099769a5p-57, 0x1.faf22263c4bd3p-1, -0x1.52ace133a2769p-58},
    {0x1.2ee285e4ab88fp-3, -0x1.e4d0f05dee058p-57, 0x1.fa5ea641c36f2p-1, 0x1.04da6ed17cc7cp-59},
    {0x1.3eb312c5d66cbp-3, 0x1.47d666b66cb91p-57, 0x1.f9c340a7cc428p-1, 0x1.c5b6b063b7462p-55},
    {0x1.4e7ea4dc5f27bp-3, 0x1.949db2ac072fcp-58, 0x1.f91ff40374d01p-1, -0x1.7d03f4d3a9e4cp-57},
    {0x1.5e44fcfa126f3p-3, -0x1.6f443063f89b6p-57, 0x1.f874c2e1eecf6p-1, -0x1.c6514e1332b16p-55},
    {0x1.6e05dc05a4d4cp-3, -0x1.32c5c8b81c919p-66, 0x1.f7c1afeffde24p-1, -0x1.8f55bc47540b1p-56},
    {0x1.7dc102fbaf2b5p-3, 0x1.5ab50e23c97c3p-59, 0x1.f706bdf9ece1cp-1, -0x1.698c80c36dcb4p-55},
    {0x1.8d7632efaa944p-3, -0x1.20fa262cbb953p-57, 0x1.f643efeb82acdp-1, 0x1.6b00ac1fe28acp-56},
    {0x1.9d252d0cec312p-3, 0x1.9c43d80b1137dp-58, 0x1.f57948cff6797p-1, 0x1.e3a0d3e03b1d4p-57},
    {0x1.accdb297a0765p-3, -0x1.9883b57d6cdeap-58, 0x1.f4a6cbd1e3a79p-1, 0x1.13df0edaebb57p-55},
    {0x1.bc6f84edc6199p-3, 0x1.9c1a56a7b0cabp-57, 0x1.f3cc7c3b3d16ep-1, -0x1.21a3ad28a3494p-57},
    {0x1.cc0a6588289a3p-3, -0x1.868d09bc87c6bp-57, 0x1.f2ea5d753ffedp-1, 0x1.cc4215f56d583p-55},
    {0x1.db9e15fb5a5d0p-3, -0x1.32e20d6cc6fc2p-57, 0x1.f20073086649fp-1, 0x1.b940416c1984bp-56},
    {0x1.eb2a57f8ae5a3p-3, -0x1.0be06af572cebp-57, 0x1.f10ec09c5873bp-1, 0x1.d9072762c1283p-55},
    {0x1.faaeed4f31577p-3, -0x1.15d88508e32b8p-57, 0x1.f01549f7deea1p-1, 0x1.d3c1e99e5cafdp-55},
    {0x1.0515cbf65155cp-2, -0x1.9b8c29dfd8ec7p-56, 0x1.ef141300d2f26p-1, -0x1.2aa1b08ded372p-55},
    {0x1.0cd00cef36436p-2, -0x1.9fb0a0c93e2b4p-56, 0x1.ee0b1fbc0f11cp-1, -0x1.bfd2380bbc3b1p-59},
    {0x1.14861aa94ddebp-2, -0x1.be881b5b615a4p-57, 0x1.ecfa744d5efa1p-1, -0x1.56d0a4af541d0p-58},
    {0x1.1c37d64c6b876p-2, 0x1.46076fe0dcff4p-56, 0x1.ebe214f76efa8p-1, -0x1.02f9f12ba543ep-55},
    {0x1.23e52111aaf36p-2, -0x1.4f080334eff18p-56, 0x1.eac2061bbaf4fp-1, 0x1.2c1d53e94658dp-57},
    {0x1.2b8ddc43eb49fp-2, 0x1.1553899f2d807p-57, 0x1.e99a4c3a7cd83p-1, -0x1.2264b1bc53ce8p-55},
    {0x1.3331e94049f87p-2, 0x1.e0cb6b40c302cp-56, 0x1.e86aebf29a9edp-1, 0x1.9397afdbb58a7p-55},
    {0x1.3ad129769d3d8p-2, 0x1.03d550487839ap-63, 0x1.e733ea0193d40p-1, -0x1.6428b3546ce13p-55},
    {0x1.426b7e69ee697p-2, -0x1.f09c75705c59fp-56, 0x1.e5f54b436e9d0p-1, 0x1.7eb0fd02fc8bcp-55},
    {0x1.4a00c9b0f3d20p-2, 0x1.823ba6bb08eadp-56, 0x1.e4af14b2a449cp-1, -0x1.68ca02e8a6833p-55},
    {0x1.5190ecf68a77ap-2, 0x1.b357155eef0f3p-56, 0x1.e3614b680d6a5p-1, -0x1.27793aa015237p-56},
    {0x1.591bc9fa2f597p-2, 0x1.7c74bac3fe0cbp-57, 0x1.e20bf49acd6c1p-1, -0x1.660aec7ef636bp-58},
    {0x1.60a1429078775p-2, 0x1.b1fd80ba89133p-58, 0x1.e0af15a03dbcep-1, 0x1.fe8e702771ae6p-58},
    {0x1.682138a38d7f7p-2, -0x1.d889202444aadp-56, 0x1.df4ab3ebd875ep-1, -0x1.e2d8a7e6736c4p-55},
    {0x1.6f9b8e33a0255p-2, 0x1.42bc14ee9da0dp-56, 0x1.ddded50f228d6p-1, -0x1.e80c8d42ba2bfp-57},
    {0x1.7710255764214p-2, -0x1.6ead7314bb6cep-57, 0x1.dc6b7eb995912p-1, 0x1.4b364776dcd35p-58},
    {0x1.7e7ee03c86d4ep-2, -0x1.b63bcdabf5af2p-56, 0x1.daf0b6b888e83p-1, 0x1.a249e2b5e5ceap-55},
    {0x1.85e7a12826949p-2, 0x1.8a40e9b5face0p-56, 0x1.d96e82f71a9dcp-1, 0x1.ff61bd5d2039dp-55},
    {0x1.8d4a4a774992fp-2, 0x1.44a02ea766326p-56, 0x1.d7e4e97e17b4ap-1, -0x1.3b770352bed94p-57},
    {0x1.94a6be9f546c5p-2, -0x1.69ce13e683f58p-56, 0x1.d653f073e4040p-1, -0x1.76236434bec37p-55},
    {0x1.9bfce02e80510p-2, 0x1.09e39a320b0a4p-56, 0x1.d4bb9e1c619e0p-1, 0x1.f34bb77858f61p-55},
    {0x1.a34c91cc50ccap-2, -0x1.a310e3b50cecdp-58, 0x1.d31bf8d8d7c06p-1, 0x1.e60dd3089cbddp-56},
    {0x1.aa95b63a09277p-2, -0x1.6293eb13c0381p-57, 0x1.d1750727d94f0p-1, 0x1.0d52b1ec1a48ep-55},
    {0x1.b1d8305321617p-2, -0x1.ae242cb99f519p-56, 0x1.cfc6cfa52ad9fp-1, 0x1.8b5b5508f2a0dp-55},
    {0x1.b913e30dbac43p-2, -0x1.e38ad2f6c3ff1p-56, 0x1.ce115909a82e5p-1, 0x1.1f139bb31109ap-55},
    {0x1.c048b17b140a3p-2, 0x1.19fe6757e9fa7p-57, 0x1.cc54aa2b2972ep-1, 0x1.4ee162ba83a98p-57},
    {0x1.c7767ec7fd19ep-2, -0x1.eb14d1a3d5826p-58, 0x1.ca90c9fc67d0bp-1, -0x1.46a81485e3462p-57},
    {0x1.ce9d2e3d4a51fp-2, -0x1.2fc8a12dae298p-57, 0x1.c8c5bf8ce1a84p-1, 0x1.ab3d1a1590123p-56},
    {0x1.d5bca34047661p-2, 0x1.28a44a75fc29cp-56, 0x1.c6f39208be53bp-1, -0x1.741dbfbaadb42p-55},
    {0x1.dcd4c15329c9ap-2, 0x1.0d4c6e171fd9ap-56, 0x1.c51a48b8b175ep-1, -0x1.1bbb43b9aa880p-57},
    {0x1.e3e56c1582a69p-2, -0x1.0a4821099f88fp-58, 0x1.c339eb01ddd81p-1, -0x1.caaf5ee82c5c0p-55},
    {0x1.eaee8744b05f0p-2, -0x1.789b43c9b027dp-58, 0x1.c1528065b7d50p-1, -0x1.892111312e828p-55},
    {0x1.f1eff6bc4f97bp-2, 0x1.17212f8a7525cp-56, 0x1.bf641081e7536p-1, 0x1.b7bd71628a9a1p-55},
    {0x1.f8e99e76abc97p-2, 0x1.9d950af2d00a3p-58, 0x1.bd6ea310294f5p-1, 0x1.31bbcc88c109dp-56},
    {0x1.ffdb628d2f57ap-2, 0x1.f4a992e905b6ap-57, 0x1.bb723fe630f32p-1, 0x1.72bd2452d0a39p-56},
    {0x1.0362939c69955p-1, -0x1.2d8cd78397b01p-55, 0x1.b96eeef58840ep-1, 0x1.45a3cc78fade0p-58},
    {0x1.06d3686946e5bp-1, 0x1.3f5ae4538ff1bp-55, 0x1.b764b84b704c2p-1, -0x1.f5848c21b389bp-55},
    {0x1.0a4021e9e1001p-1, -0x1.6f643a13914f6p-55, 0x1.b553a410c104ep-1, 0x1.8ff7947027a15p-58},
    {0x1.0da8b26b5672ep-1, -0x1.a58def0bee909p-55, 0x1.b33bba89c8948p-1, 0x1.ea6a51d1f6ca9p-55},
    {0x1.110d0c4b69c3bp-1, 0x1.d918998809981p-55, 0x1.b11d04162a4c6p-1, 0x1.1dd561efbc0c2p-56},
    {0x1.146d21f8b7f82p-1, 0x1.bf9535e2739a8p-56, 0x1.aef78930bd275p-1, -0x1.f836279746f94p-56},
    {0x1.17c8e5f2eedb0p-1, 0x1.35e57102e2488p-57, 0x1.accb526f69de5p-1, 0x1.8fb6a8dd6b6ccp-55},
    {0x1.1b204acb02fddp-1, -0x1.f190c70cbb5fep-58, 0x1.aa98688308913p-1, -0x1.b83d607cd5072p-63},
    {0x1.1e7343236574cp-1, 0x1.22a3fa4f41d5ap-56, 0x1.a85ed4373e02dp-1, 0x1.9be06385ec792p-57},
    {0x1.21c1c1b0394cfp-1, 0x1.e5b324b23aa31p-58, 0x1.a61e9e72586afp-1, 0x1.58330e2fd453fp-55},
    {0x1.250bb93788bbbp-1, 0x1.ea3d02457bccep-56, 0x1.a3d7d0352bdcfp-1, -0x1.68dbaeca19669p-55},
    {0x1.28511c917a067p-1, -0x1.01df1d9a16b70p-55, 0x1.a18a729aee445p-1, 0x1.95e25736c0357p-60},
    {0x1.2b91dea88421ep-1, -0x1.fa371db216ab0p-55, 0x1.9f368ed912f85p-1, -0x1.1d200c5791606p-55},
    {0x1.2ecdf279a3082p-1, 0x1.d3557e0e7e37ep-55, 0x1.9cdc2e3f25e5cp-1, 0x1.3f99112993f62p-55},
    {0x1.32054b148bc4fp-1, 0x1.f6b42095a135bp-55, 0x1.9a7b5a36a6514p-1, 0x1.722cfcc9fa7a9p-55},
    {0x1.3537db9be0367p-1, 0x1.b327e7af040f0p-57, 0x1.98141c42e1310p-1, 0x1.d1ff80488f08dp-55},
    {0x1.386597456282bp-1, -0x1.10fada93b07a8p-56, 0x1.95a67e00cb1fdp-1, -0x1.0befda21f862dp-55},
    {0x1.3b8e715a2840ap-1, -0x1.97653a7d2f07ap-56, 0x1.93328926d9e92p-1, -0x1.bb77003600cdap-55},
    {0x1.3eb25d36cd53ap-1, -0x1.be570e1570fc0p-58, 0x1.90b84784ddaf7p-1, -0x1.0feb10ab93b87p-56},
    {0x1.41d14e4ba6790p-1, 0x1.4608fd287ecf5p-55, 0x1.8e37c303d9ad1p-1, -0x1.463a4b53d4bf8p-57},
    {0x1.44eb381cf386bp-1, -0x1.3ed6c1e6a5505p-55, 0x1.8bb105a5dc900p-1, 0x1.863e03e9474c1p-55},
    {0x1.48000e431159fp-1, -0x1.b194a7463ed10p-55, 0x1.89241985d871fp-1, 0x1.c48d9c413ed84p-55},
    {0x1.4b0fc46aab761p-1, 0x1.0da05738cc59cp-61, 0x1.869108d77a6c6p-1, 0x1.338ffe2bfe9ddp-56},
    {0x1.4e1a4e54ed51bp-1, -0x1.a492f89b7c76ap-55, 0x1.83f7dde701ca0p-1, -0x1.152cf609bc6e8p-59},
    {0x1.511f9fd7b351cp-1, -0x1.5c0e861c48831p-55, 0x1.8158a31916d5dp-1, -0x1.de8b90b8228dep-57},
    {0x1.541facddbb724p-1, 0x1.232c28520d391p-56, 0x1.7eb362eaa1488p-1, 0x1.a1d65a4a5959fp-58},
    {0x1.571a6966d59b3p-1, 0x1.c843b4d0fb197p-58, 0x1.7c0827f09e54fp-1, -0x1.c73d6d72aee68p-57},
    {0x1.5a0fc98813a12p-1, -0x1.d82e2b7d4227bp-55, 0x1.7956fcd7f6543p-1, -0x1.ab276e9d45ae4p-55},
    {0x1.5cffc16bf8f0dp-1, 0x1.96cb370eb578ap-55, 0x1.769fec655211fp-1, -0x1.827d5cf8c68c5p-57},
    {0x1.5fea4552a9e57p-1, 0x1.0b6cef7ee20b7p-55, 0x1.73e30174efba1p-1, -0x1.5d3ae3d94ad5fp-57},
    {0x1.62cf49921ac79p-1, -0x1.edd9855b6241ap-55, 0x1.712046fa77678p-1, 0x1.425b0a5029c81p-55},
    {0x1.65aec2963e755p-1, 0x1.126f96b71053cp-55, 0x1.6e57c800cf55ep-1, 0x1.60286dedbd0a6p-55},
    {0x1.6888a4e134b2fp-1, -0x1.6b7d37644d5e6p-55, 0x1.6b898fa9efb5dp-1, 0x1.15ac786ccf4b2p-56},
    {0x1.6b5ce50b7821ap-1, -0x1.5d5158f702e0fp-57, 0x1.68b5a92eb6253p-1, -0x1.9a91ad985f89cp-55},
    {0x1.6e2b77c40bde1p-1, -0x1.0e729857fad53p-56, 0x1.65dc1fdeb8cbap-1, -0x1.97c1b47337c77p-58},
    {0x1.70f451d0a8c40p-1, 0x1.97ede3885770dp-57, 0x1.62fcff20191c7p-1, 0x1.d9143895756efp-57}};

/* sin r and cos r, r = rh + rl (|rl| <= ulp(rh)), to ~2^-95 relative in double-double, each
 * rounded once: the reference computation (slow: Taylor series in double-double) */
static void sincos_slow(double rh, double rl, double *ss, double *cc)
{
    double zh, zl, sh, sl, cl;
    dd_mul(rh, rl, rh, rl, &zh, &zl);
    series(zh, zl, 1, &sh, &sl);
    dd_mul(sh, sl, rh, rl, ss, &sl);
    series(zh, zl, 0, cc, &cl);
}

/* 1 if hi is the correctly rounded value of every number within err of hi + lo (|lo| <= half
 * an ulp of hi): rounding is monotone, so both ends rounding to hi suffices (Ziv's test) */
static int rounds_to(double hi, double lo, double err)
{
    return hi + (lo + err) == hi && hi + (lo - err) == hi;
}

/* sin r and cos r for r = rh + rl, |rh| <= 0.8, by a table: r = +-(a + d), a = i/128 the
 * nearest, |d| <= 1/256; sin(a + d) = sin a cos d + cos a sin d, cos(a + d) = cos a cos d -
 * sin a sin d with sin a, cos a in double-double and sin d - d, cos d - 1 by their Taylor
 * polynomials (truncation below 2^-85 relative). The leading products are exact (two_prod),
 * the rest (below 2^-16 of the result) in double: error below 2^-64 of the result. Where the
 * correct rounding is not certain within 2^-62 (about 0.3 % of arguments) the slow path
 * decides, so the results are sincos_slow's bits. */
static void sincos_fast(double rh, double rl, double *ss, double *cc)
{
    /* Taylor coefficients (correctly rounded): 1/3!, 1/5!, 1/7!, 1/9!; 1/2!, 1/4!, 1/6!, 1/8! */
    static const double S3 = 0x1.5555555555555p-3, S5 = 0x1.1111111111111p-7,
                        S7 = 0x1.a01a01a01a01ap-13, S9 = 0x1.71de3a556c734p-19,
                        C4 = 0x1.5555555555555p-5, C6 = 0x1.6c16c16c16c17p-10,
                        C8 = 0x1.a01a01a01a01ap-16;
    static const double TOL = 0x1.0p-62;   /* 4x the error bound, relative */
    const int neg = rh < 0.0;
    const double ar = neg ? -rh : rh, al = neg ? -rl : rl;
    const int i = ((int)(ar * 256.0) + 1) >> 1;        /* exact: ar in [a - 2^-8, a + 2^-8) */
    const double *t = SINCOS_TAB[i];
    const double sah = t[0], sal = t[1], cah = t[2], cal = t[3];
    const double dh = ar - (double)i * 0x1.0p-7;      /* exact (Sterbenz; i = 0: dh = ar) */
    const double z = dh * dh;
    const double sd3 = dh * (z * (-S3 + z * (S5 + z * (-S7 + z * S9))));   /* sin d - d */
    const double cm = z * (-0.5 + z * (C4 + z * (-C6 + z * C8))) - dh * al;  /* cos d - 1 */
    double p, pe, s, e, tail, hi, lo;
    /* sin: sa + ca dh (exact pair) + the small terms */
    two_prod(cah, dh, &p, &pe);
    two_sum(sah, p, &s, &e);
    tail = e + (pe + ((sal + cal * dh + cah * al) + (sah * cm + cah * sd3)));
    hi = s + tail;
    lo = tail - (hi - s);
    if (rounds_to(hi, lo, TOL * fabs(hi)))
        *ss = neg ? -hi : hi;
    else
        *ss = 2.0;                          /* undecided: no sine is 2 */
    /* cos: ca - sa dh (exact pair) + the small terms */
    two_prod(sah, dh, &p, &pe);
    two_sum(cah, -p, &s, &e);
    tail = e + (-pe + ((cal - sal * dh - sah * al) + (cah * cm - sah * sd3)));
    hi = s + tail;
    lo = tail - (hi - s);
    *cc = rounds_to(hi, lo, TOL * fabs(hi)) ? hi : 2.0;
    if (*ss == 2.0 || *cc == 2.0) {
        double s2, c2;
        sincos_slow(rh, rl, &s2, &c2);
        if (*ss == 2.0)
            *ss = s2;
        if (*cc == 2.0)
            *cc = c2;
    }
}

void sr_sincos(double x, double *s, double *c)
{
    /* pi/2 in four parts, the first three of 33 significant bits (k P_i exact for
     * |k| < 2^20), 152 bits in all: x - k pi/2 keeps its accuracy next to multiples of pi/2 */
    static const double P1 = 0x1.921fb54400000p+0, P2 = 0x1.0b4611a600000p-34,
                        P3 = 0x1.3198a2e000000p-69, P3T = 0x1.b839a252049c1p-104;
    static const double TWO_OVER_PI = 0x1.45f306dc9c883p-1, PIO4 = 0x1.921fb54442d18p-1;
    double k, rh, rl, ss, cc;
    long long q;
    if (!(fabs(x) < 1e15)) {                /* non-finite or beyond any meaningful angle */
        if (s) *s = NAN;
        if (c) *c = NAN;
        return;
    }
    if (fabs(x) < 0x1.0p-27) {              /* x^3/6, x^2/2 below a quarter ulp: x and 1 are
                                             * the correctly rounded values (+-0 kept) */
        if (s) *s = x;
        if (c) *c = 1.0;
        return;
    }
    if (fabs(x) <= PIO4) {
        k = 0.0;
        rh = x;
        rl = 0.0;
    } else {
        /* r = x - k pi/2 in double-double: x - k P1 exact (k P1 exact, then Sterbenz),
         * - k P2 (exact product) with its rounding error kept, then the small parts */
        double t, e1;
        k = floor(x * TWO_OVER_PI + 0.5);   /* nearest quadrant */
        two_sum(x - k * P1, -(k * P2), &t, &e1);
        two_sum(t, (e1 - k * P3) - k * P3T, &rh, &rl);
    }
    /* sin r, cos r correctly rounded: the table path, the double-double series where that
     * cannot decide (and for |r| > 0.8, reached only for |x| beyond 1.6e6) */
    if (fabs(rh) <= 0.8)
        sincos_fast(rh, rl, &ss, &cc);
    else
        sincos_slow(rh, rl, &ss, &cc);
    q = (long long)k % 4;                   /* k integral, |k| < 2^50: exact */
    if (q < 0)
        q += 4;
    switch (q) {
    case 0: if (s) *s = ss;  if (c) *c = cc;  break;
    case 1: if (s) *s = cc;  if (c) *c = -ss; break;
    case 2: if (s) *s = -ss; if (c) *c = -cc; break;
    default: if (s) *s = -cc; if (c) *c = ss; break;
    }
}

double sr_sin(double x)
{
    double s;
    sr_sincos(x, &s, NULL);
    return s;
}

double sr_cos(double x)
{
    double c;
    sr_sincos(x, NULL, &c);
    return c;
}

/* -- arc tangent ------------------------------------------------------------------------------ */

/* fdlibm's s_atan.c: atan x = atan c + atan((x - c) / (1 + x c)) for the breakpoints
 * c = 1/2, 1, 3/2, inf (atan c in two parts), the rest by an odd polynomial of degree 23 */
double sr_atan(double x)
{
    static const double atanhi[4] = {4.63647609000806093515e-01, 7.85398163397448278999e-01,
                                     9.82793723247329054082e-01, 1.57079632679489655800e+00};
    static const double atanlo[4] = {2.26987774529616870924e-17, 3.06161699786838301793e-17,
                                     1.39033110312309984516e-17, 6.12323399573676603587e-17};
    static const double aT[11] = {
        3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01,
        -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02,
        6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02,
        -3.65315727442169155270e-02, 1.62858201153657823623e-02};
    double ax, z, w, s1, s2, r;
    int id, neg;
    if (isnan(x))
        return x + x;
    neg = x < 0.0;
    ax = fabs(x);
    if (ax >= 7.3786976294838206464e19) {             /* 2^66: atan x = pi/2 to the last bit */
        r = atanhi[3] + atanlo[3];
        return neg ? -r : r;
    }
    if (ax < 0.4375) {
        if (ax < 7.4505805969238281e-09)               /* 2^-27: atan x = x */
            return x;
        id = -1;
    } else if (ax < 1.1875) {
        if (ax < 0.6875) {
            id = 0;
            ax = (2.0 * ax - 1.0) / (2.0 + ax);
        } else {
            id = 1;
            ax = (ax - 1.0) / (ax + 1.0);
        }
    } else if (ax < 2.4375) {
        id = 2;
        ax = (ax - 1.5) / (1.0 + 1.5 * ax);
    } else {
        id = 3;
        ax = -1.0 / ax;
    }
    z = ax * ax;
    w = z * z;
    s1 = z * (aT[0] + w * (aT[2] + w * (aT[4] + w * (aT[6] + w * (aT[8] + w * aT[10])))));
    s2 = w * (aT[1] + w * (aT[3] + w * (aT[5] + w * (aT[7] + w * aT[9]))));
    if (id < 0) {
        r = ax - ax * (s1 + s2);
        return neg ? -r : r;
    }
    r = atanhi[id] - ((ax * (s1 + s2) - atanlo[id]) - ax);
    return neg ? -r : r;
}

double sr_atan2(double y, double x)
{
    static const double pi = 3.141592653589793, pi_lo = 1.2246467991473531772e-16;
    double z;
    if (isnan(x) || isnan(y))
        return x + y;
    if (x == 0.0) {
        if (y == 0.0)
            return 0.0;
        return y > 0.0 ? 0.5 * pi : -0.5 * pi;
    }
    if (y == 0.0)
        return x > 0.0 ? y : (signbit(y) ? -pi : pi);
    z = sr_atan(fabs(y / x));
    if (x > 0.0)
        return y > 0.0 ? z : -z;
    return y > 0.0 ? pi - (z - pi_lo) : (z - pi_lo) - pi;   /* pi in two parts */
}

/* -- logarithms ------------------------------------------------------------------------------- */

/* x finite > 0: x = 2^k (1 + f), 1 + f in [sqrt(1/2), sqrt(2)] (f exact); then s = f / (2 + f),
 * hfsq = f^2 / 2 and R with log(1 + f) = f - (hfsq - s (hfsq + R)) */
static void log_reduce(double x, int *k_out, double *f_out, double *s_out, double *hfsq_out,
                       double *R_out)
{
    static const double SQRT2 = 0x1.6a09e667f3bcdp+0;
    uint64_t b;
    int k = 0, i;
    double m, f, s, z, R;
    if (x < 0x1.0p-1022) {                  /* subnormal: scale into the normal range (exact) */
        x *= 0x1.0p+54;
        k = -54;
    }
    b = to_bits(x);
    k += (int)((b >> 52) & 0x7ff) - 1023;
    m = from_bits((b & UINT64_C(0x000fffffffffffff)) | UINT64_C(0x3ff0000000000000)); /* [1, 2) */
    if (m > SQRT2) {                        /* m in [sqrt(1/2), sqrt(2)]: |f| <= 0.42 */
        m *= 0.5;
        k += 1;
    }
    f = m - 1.0;                            /* exact (Sterbenz) */
    /* log(1 + f) = 2 atanh(s), s = f / (2 + f), |s| <= 0.172:
     * = f - (hfsq - s (hfsq + R)), R = 2 (z/3 + z^2/5 + ...), z = s^2 <= 0.0295; the series
     * is cut after z^12 (0.0295^13 / 27 < 2^-70 of the result) */
    s = f / (2.0 + f);
    z = s * s;
    R = 0.0;
    for (i = 12; i >= 1; --i)
        R = (R + 2.0 / (double)(2 * i + 1)) * z;    /* exact-rounded division: portable */
    *k_out = k;
    *f_out = f;
    *s_out = s;
    *hfsq_out = 0.5 * f * f;
    *R_out = R;
}

/* the special values of both logarithms; 1 if x needs no computation (*y set) */
static int log_special(double x, double *y)
{
    if (x != x)
        *y = x;
    else if (x < 0.0)
        *y = NAN;
    else if (x == 0.0)
        *y = -HUGE_VAL;
    else if (x > 0x1.fffffffffffffp+1023)
        *y = x;                             /* +inf */
    else
        return 0;
    return 1;
}

double sr_ln(double x)
{
    /* ln 2 in two parts: LN2_HI has 32 significant bits, so k LN2_HI is exact for |k| < 2^21 */
    static const double LN2_HI = 0x1.62e42fee00000p-1, LN2_LO = 0x1.a39ef35793c76p-33;
    int k;
    double f, s, hfsq, R, dk, y;
    if (log_special(x, &y))
        return y;
    log_reduce(x, &k, &f, &s, &hfsq, &R);
    dk = (double)k;
    return dk * LN2_HI - ((hfsq - (s * (hfsq + R) + dk * LN2_LO)) - f);
}

double sr_log10(double x)
{
    /* 1/ln 10 and log10(2) in two parts each; the high parts have at most 33 significant
     * bits, so hi IVLN10_HI (hi of 21 bits) and k LOG10_2HI are exact (FreeBSD e_log10.c) */
    static const double IVLN10_HI = 0x1.bcb7b15200000p-2, IVLN10_LO = 0x1.b9438ca9aadd5p-36,
                        LOG10_2HI = 0x1.34413509f6000p-2, LOG10_2LO = 0x1.9fef311f12b36p-42;
    int k;
    double f, s, hfsq, R, dk, y, hi, lo, val_hi, val_lo, y2, w;
    if (log_special(x, &y))
        return y;
    log_reduce(x, &k, &f, &s, &hfsq, &R);
    /* log(1 + f) = hi + lo with hi = f - hfsq cut to 21 significant bits (low word cleared) */
    hi = from_bits(to_bits(f - hfsq) & UINT64_C(0xffffffff00000000));
    lo = (f - hi) - hfsq + s * (hfsq + R);
    dk = (double)k;
    val_hi = hi * IVLN10_HI;
    y2 = dk * LOG10_2HI;
    val_lo = dk * LOG10_2LO + (lo + hi) * IVLN10_LO + lo * IVLN10_HI;
    w = y2 + val_hi;                        /* the sum of the two large parts, its error kept */
    val_lo += (y2 - w) + val_hi;
    return val_lo + w;
}

/* -- integer powers --------------------------------------------------------------------------- */

/* (ah + al) 2^ae *= (bh + bl) 2^be in double-double, renormalised to ah in [1, 2) */
static void dd_mul_exp(double *ah, double *al, long long *ae, double bh, double bl, long long be)
{
    double p, e, h, l;
    two_prod(*ah, bh, &p, &e);
    e += *ah * bl + *al * bh;
    fast_two_sum(p, e, &h, &l);
    *ae += be;
    if (h >= 2.0) {                         /* exact: powers of two, no subnormals here */
        h *= 0.5;
        l *= 0.5;
        *ae += 1;
    }
    *ah = h;
    *al = l;
}

double sr_powi(double x, int n)
{
    double ax, m, bh, bl = 0.0, ah = 1.0, al = 0.0, r;
    long long be = 0, ae = 0, e;
    unsigned int un;
    int neg, ex, adj = 0;
    uint64_t b;
    if (n == 0)
        return 1.0;
    if (x != x)
        return x;
    neg = signbit(x) && (n & 1);            /* an odd power keeps the sign */
    ax = fabs(x);
    if (ax == 0.0 || ax > 0x1.fffffffffffffp+1023) {
        r = ((ax == 0.0) == (n > 0)) ? 0.0 : HUGE_VAL;
        return neg ? -r : r;
    }
    if (ax < 0x1.0p-1022) {                 /* subnormal: scale into the normal range (exact) */
        ax *= 0x1.0p+54;
        adj = -54;
    }
    b = to_bits(ax);
    ex = (int)((b >> 52) & 0x7ff) - 1023 + adj;
    m = from_bits((b & UINT64_C(0x000fffffffffffff)) | UINT64_C(0x3ff0000000000000)); /* [1, 2) */
    /* m^|n| by squaring (|n| as unsigned: INT_MIN too) */
    un = n < 0 ? 0u - (unsigned int)n : (unsigned int)n;
    bh = m;
    for (;;) {
        if (un & 1u)
            dd_mul_exp(&ah, &al, &ae, bh, bl, be);
        un >>= 1;
        if (!un)
            break;
        dd_mul_exp(&bh, &bl, &be, bh, bl, be);
    }
    e = (long long)ex * (n < 0 ? -(long long)n : (long long)n) + ae;
    if (n < 0) {
        /* 1 / (ah + al): q = 1/ah corrected by the exact residual 1 - q (ah + al) */
        double q = 1.0 / ah, p, pe, res;
        two_prod(q, ah, &p, &pe);
        res = ((1.0 - p) - pe) - q * al;    /* 1 - p exact (Sterbenz) */
        fast_two_sum(q, res * q, &ah, &al);
        e = -e;
        if (ah < 1.0) {                     /* (1/2, 1]: back to [1, 2) */
            ah *= 2.0;
            al *= 2.0;
            e -= 1;
        }
    }
    /* one rounding for a normal result; hi and lo scaled apart in the subnormal range */
    r = e >= -1022 ? scale2(ah + al, e) : scale2(ah, e) + scale2(al * 0x1.0p+60, e - 60);
    return neg ? -r : r;
}

double sr_pow10(int n)
{
    return sr_powi(10.0, n);
}

/* ln P(|Z| > z) at x = z / sqrt 2 (sr_normal_quantile2) */
static double ln_two_sided_tail(double x)
{
    double t = x;
    for (int n = 1000; n >= 1; n--)
        t = x + 0.5 * n / t;                      /* K(x), backwards */
    return -x * x - 0.57236494292470008707 - sr_ln(t);    /* ln sqrt(pi) */
}

double sr_normal_quantile2(double p)
{
    if (!(p >= 1e-300 && p <= 0.5))
        return NAN;
    const double target = sr_ln(p);
    double lo = 0.4, hi = 26.6;                   /* tails e^-0.2 .. below 1e-300 */
    for (int i = 0; i < 200 && hi - lo > 0.0; i++) {
        const double mid = 0.5 * (lo + hi);
        if (mid <= lo || mid >= hi)
            break;
        if (ln_two_sided_tail(mid) > target)
            lo = mid;
        else
            hi = mid;
    }
    return 1.41421356237309504880 * 0.5 * (lo + hi);
}

double sr_exp(double x)
{
    static const double LN2_HI = 6.93147180369123816490e-01;   /* 0x3fe62e42 fee00000 */
    static const double LN2_LO = 1.90821492927058770002e-10;
    static const double INV_LN2 = 1.44269504088896338700e+00;
    if (x != x)
        return x;
    if (x > 709.782712893384)
        return HUGE_VAL;
    if (x < -745.1332191019412)
        return 0.0;
    const double k = nearbyint(x * INV_LN2);
    const double r = (x - k * LN2_HI) - k * LN2_LO;
    double p = 1.0;                                /* 1 + r/1 (1 + r/2 (... (1 + r/13))) */
    for (int n = 13; n >= 1; n--)
        p = 1.0 + r * p / n;
    return ldexp(p, (int)k);
}
