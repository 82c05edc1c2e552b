"""The native sensor models (native/src/sensors.c) and their portable random generator
(native/src/rng.c).

Generator: xoshiro256** and splitmix64 against the published reference outputs (the reference C
code's, as quoted by rand_xoshiro; PHP's test of jump + long_jump), uniforms and polar-method
normals against a pure-Python transcription (normals to 4e-16 relative: Python's log is not the
portable one), the portable log / sine / cosine to 1 ulp of the C library's (sine and cosine
2 ulp for |x| > 4 rad), the normals' first four moments to 5 standard errors and a
Kolmogorov-Smirnov test (p > 1e-3) over 10^6 draws, and the same bits from a mingw build under
Wine as from the native build (skipped without mingw or Wine; in the test process's Wine
prefix, tests/wine.py, from an empty environment).

Sensors against the NumPy reference SensorSuite (tests/oracles/sensors.py, NumPy's generator:
the same statistics, not the same numbers), per channel: white noise standard deviations and means over
10000 samples, the bias random walks' increments and the growth of their variance with time
(k = 10 and 40 steps) over 1000 runs (C) and 300 (Python), initial biases and the thrust scale factor and
misalignment over 2000 seeds. Tolerance: 5 standard errors of the difference of the two
estimates (sd: sd / sqrt(2 m) each; mean: sd / sqrt(m) each; variance: var sqrt(2 / m) each,
m the number of samples), and the same against the configured value. Exact properties:
noise.scale = 0 passes the sample on bit for bit, a seed fixes the run, the delay is exactly
noise.delay samples, quantisation is res * round(q / res) with NumPy's rounding (ties to even),
the impulses follow the known thrust (1e-12 relative, NumPy).

The library under test is ``$SPACEROBOT_CORE_LIB`` when set, else a fresh build of the modules
this file needs (native/build.py, warnings as errors).
"""
from __future__ import annotations

import ctypes
import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from numpy.ctypeslib import ndpointer

import native_hosts
from test_sensors import true_sample, zero_except  # the same samples and parameters
from spacerobot.interface import NOISE_PARAMETERS
from oracles.sensors import SensorSuite
from spacerobot.sensors import SIGNALS, default_parameters

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "native" / "src"
SOURCES = ["sr_math.c", "sr_text.c", "sample.c", "rng.c", "sensor_noise.c", "sensors.c"]
N_JOINTS, DT = 6, 0.1
MAX_JOINTS, MAX_DELAY = 12, 100
M64 = (1 << 64) - 1


def build_core(tmp_dir: Path) -> ctypes.CDLL:
    """``$SPACEROBOT_CORE_LIB``, else the modules of SOURCES built by native/build.py."""
    return native_hosts.build_core(tmp_dir, SOURCES)


class Rng(ctypes.Structure):
    """sr_rng (rng.h)."""
    _fields_ = [("s", ctypes.c_uint64 * 4), ("spare", ctypes.c_double),
                ("has_spare", ctypes.c_int32), ("reserved", ctypes.c_int32)]


def _f64(*shape):
    return ctypes.c_double * int(np.prod(shape))


class State(ctypes.Structure):
    """sr_sensors_state (sensors.h), to read and corrupt it in tests."""
    _fields_ = [("rng", Rng * 6), ("gyro_bias", _f64(3)), ("accel_bias", _f64(3)),
                ("E_F", _f64(9)), ("E_M", _f64(9)), ("H_err", _f64(3)),
                ("d_omega", _f64(3)), ("d_att", _f64(3)), ("d_r", _f64(3)), ("d_v", _f64(3)),
                ("d_a", _f64(3)), ("d_alpha", _f64(3)), ("d_q", _f64(MAX_JOINTS)),
                ("d_qd", _f64(MAX_JOINTS)), ("d_qdd", _f64(MAX_JOINTS)),
                ("count", ctypes.c_int32), ("head", ctypes.c_int32),
                ("line", _f64(MAX_DELAY, 24 + 3 * MAX_JOINTS + 12))]


D = ndpointer(np.float64, flags="C_CONTIGUOUS")
c_int, c_double, c_void_p = ctypes.c_int, ctypes.c_double, ctypes.c_void_p
RNG_P = ctypes.POINTER(Rng)


@pytest.fixture(scope="module")
def lib(tmp_path_factory):
    L = build_core(tmp_path_factory.mktemp("core_sensors"))
    sig = {
        "sr_splitmix64": (ctypes.c_uint64, [ctypes.POINTER(ctypes.c_uint64)]),
        "sr_rng_seed": (None, [RNG_P, ctypes.c_uint64]),
        "sr_rng_set_state": (None, [RNG_P, ctypes.POINTER(ctypes.c_uint64)]),
        "sr_rng_next": (ctypes.c_uint64, [RNG_P]),
        "sr_rng_jump": (None, [RNG_P]),
        "sr_rng_long_jump": (None, [RNG_P]),
        "sr_rng_uniform": (c_double, [RNG_P]),
        "sr_rng_normal": (c_double, [RNG_P]),
        "sr_rng_uniforms": (None, [RNG_P, c_int, D]),
        "sr_rng_normals": (None, [RNG_P, c_int, D]),
        "sr_portable_log": (c_double, [c_double]),
        "sr_portable_sincos": (None, [c_double, ctypes.POINTER(c_double), ctypes.POINTER(c_double)]),
        "sr_sensors_model_size": (ctypes.c_size_t, []),
        "sr_sensors_state_size": (ctypes.c_size_t, []),
        "sr_sensors_parameter_name": (ctypes.c_char_p, [c_int]),
        "sr_sensors_init": (c_int, [c_void_p, c_int, D, c_double, ctypes.c_longlong, c_int,
                                    c_int, c_double, ctypes.c_char_p, c_int]),
        "sr_sensors_start": (c_int, [c_void_p, c_void_p]),
        "sr_sensors_measure": (c_int, [c_void_p, c_void_p, D, D]),
        "sr_sensors_advance": (c_int, [c_void_p, c_void_p, D, c_double]),
        "sr_sensors_update": (c_int, [c_void_p, c_void_p, D, c_double, D]),
        "sr_rotation_vector_to_matrix": (None, [D, D]),
    }
    for name, (res, args) in sig.items():
        f = getattr(L, name)
        f.restype, f.argtypes = res, args
    return L


# -- a pure-Python transcription of the reference generators ----------------------------------
def splitmix64(x):
    x = (x + 0x9E3779B97F4A7C15) & M64
    z = x
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & M64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & M64
    return x, z ^ (z >> 31)


class PyXoshiro:
    def __init__(self, s):
        self.s = list(s)

    @classmethod
    def seeded(cls, seed):
        s, x = [], seed
        for _ in range(4):
            x, z = splitmix64(x)
            s.append(z)
        return cls(s)

    def next(self):
        s = self.s
        rotl = lambda v, k: ((v << k) | (v >> (64 - k))) & M64  # noqa: E731
        r = (rotl((s[1] * 5) & M64, 7) * 9) & M64
        t = (s[1] << 17) & M64
        s[2] ^= s[0]; s[3] ^= s[1]; s[1] ^= s[2]; s[0] ^= s[3]; s[2] ^= t       # noqa: E702
        s[3] = rotl(s[3], 45)
        return r

    def uniform(self):
        return (self.next() >> 11) * 2.0 ** -53

    def normals(self, count):
        """Marsaglia's polar method, both normals of a pair, Python's log."""
        out = []
        while len(out) < count:
            u, v = 2.0 * self.uniform() - 1.0, 2.0 * self.uniform() - 1.0
            s = u * u + v * v
            if 0.0 < s < 1.0:
                f = math.sqrt(-2.0 * math.log(s) / s)
                out += [u * f, v * f]
        return out[:count]


def c_rng(lib, seed=None, state=None) -> Rng:
    g = Rng()
    if state is not None:
        lib.sr_rng_set_state(ctypes.byref(g), (ctypes.c_uint64 * 4)(*state))
    else:
        lib.sr_rng_seed(ctypes.byref(g), seed)
    return g


# -- the generator ----------------------------------------------------------------------------
@pytest.mark.slow
def test_xoshiro_and_splitmix_reference_outputs(lib):
    # xoshiro256starstar.c from the state {1, 2, 3, 4} (rand_xoshiro's test "reference")
    ref = [11520, 0, 1509978240, 1215971899390074240, 1216172134540287360, 607988272756665600,
           16172922978634559625, 8476171486693032832, 10595114339597558777, 2904607092377533576]
    g = c_rng(lib, state=[1, 2, 3, 4])
    assert [lib.sr_rng_next(ctypes.byref(g)) for _ in ref] == ref
    # splitmix64.c from 1477776061723855037 (rand_xoshiro's SplitMix64 test "reference")
    x = ctypes.c_uint64(1477776061723855037)
    assert [lib.sr_splitmix64(ctypes.byref(x)) for _ in range(5)] == [
        1985237415132408290, 2979275885539914483, 13511426838097143398, 8488337342461049707,
        15141737807933549159]
    # seeding = four splitmix64 outputs; jump and long_jump: PHP's test
    # ext/random/tests/02_engine/xoshiro256starstar_value.phpt (seed 1234, 10000 outputs,
    # jump, long jump: the next output's little-endian bytes are 1f197e9ca7969123)
    g = c_rng(lib, seed=1234)
    for _ in range(10000):
        lib.sr_rng_next(ctypes.byref(g))
    lib.sr_rng_jump(ctypes.byref(g))
    lib.sr_rng_long_jump(ctypes.byref(g))
    assert lib.sr_rng_next(ctypes.byref(g)).to_bytes(8, "little").hex() == "1f197e9ca7969123"
    assert ctypes.sizeof(Rng) == 48
    # an all-zero state (xoshiro's fixed point) is replaced by a valid one
    z = c_rng(lib, state=[0, 0, 0, 0])
    assert any(z.s) and lib.sr_rng_next(ctypes.byref(z)) != 0


def test_uniforms_and_normals_follow_their_definitions(lib):
    for seed in (0, 1, 2 ** 63 + 5):
        py, g = PyXoshiro.seeded(seed), c_rng(lib, seed)
        assert list(g.s) == py.s                               # splitmix64 seeding
        u = np.empty(1000)
        lib.sr_rng_uniforms(ctypes.byref(g), 1000, u)
        assert u.tolist() == [py.uniform() for _ in range(1000)]   # exact: 53 bits * 2^-53
        assert u.min() >= 0.0 and u.max() < 1.0
        py, g = PyXoshiro.seeded(seed), c_rng(lib, seed)
        z = np.empty(2001)
        lib.sr_rng_normals(ctypes.byref(g), 2001, z)
        ref = np.array(py.normals(2002))
        # the same pairs accepted (same uniforms), values to the log's rounding
        assert np.all(np.abs(z - ref[:-1]) <= 4e-16 * np.abs(ref[:-1]))
        assert g.has_spare == 1                                # 2001: the pair's second kept
        z2002 = lib.sr_rng_normal(ctypes.byref(g))
        assert abs(z2002 - ref[-1]) <= 4e-16 * abs(ref[-1]) and g.has_spare == 0


def test_portable_log_sine_and_cosine_within_one_ulp(lib):
    rng = np.random.default_rng(1)
    xs = np.concatenate([np.exp(rng.uniform(-700, 700, 20000)), rng.uniform(0.5, 2.0, 20000),
                         [1.0, 2.0, 0.5, 1e-310, 5e-324, 1.7976931348623157e308,
                          np.nextafter(1.0, 2.0), np.nextafter(1.0, 0.0)]])
    got = np.array([lib.sr_portable_log(float(x)) for x in xs])
    ref = np.log(xs)
    ulp = np.spacing(np.abs(ref))
    assert np.all(np.abs(got - ref) <= ulp + 1e-300), np.max(np.abs(got - ref) / ulp)
    assert lib.sr_portable_log(1.0) == 0.0
    assert lib.sr_portable_log(0.0) == -np.inf and np.isnan(lib.sr_portable_log(-1.0))
    s, c = ctypes.c_double(), ctypes.c_double()
    angles = np.concatenate([rng.uniform(-4, 4, 20000), rng.uniform(-1e4, 1e4, 5000),
                             [0.0, -0.0, np.pi / 4, np.pi / 2, np.pi, 1e-9]])
    got = []
    for a in angles:
        lib.sr_portable_sincos(float(a), ctypes.byref(s), ctypes.byref(c))
        got.append((s.value, c.value))
    got = np.array(got)
    for k, ref in enumerate((np.sin(angles), np.cos(angles))):
        err = np.abs(got[:, k] - ref) / np.spacing(np.abs(ref))
        small = np.abs(angles) <= 4.0             # no reduction error: 1 ulp; else 2 ulp
        assert err[small].max() <= 1.0 and err.max() <= 2.0, (k, err.max(), angles[err.argmax()])
    for bad in (np.inf, -np.inf, np.nan, 1e300):
        lib.sr_portable_sincos(bad, ctypes.byref(s), ctypes.byref(c))
        assert np.isnan(s.value) and np.isnan(c.value)


def test_normals_moments_and_kolmogorov_smirnov(lib):
    from scipy import stats
    n = 1_000_000
    g = c_rng(lib, 2024)
    z = np.empty(n)
    lib.sr_rng_normals(ctypes.byref(g), n, z)
    assert abs(z.mean()) < 5 / np.sqrt(n)
    assert abs(z.var() - 1.0) < 5 * np.sqrt(2.0 / n)
    assert abs(stats.skew(z)) < 5 * np.sqrt(6.0 / n)
    assert abs(stats.kurtosis(z)) < 5 * np.sqrt(24.0 / n)
    assert stats.kstest(z, "norm").pvalue > 1e-3
    # streams after a jump: uncorrelated with the first
    h = c_rng(lib, 2024)
    lib.sr_rng_jump(ctypes.byref(h))
    w = np.empty(n)
    lib.sr_rng_normals(ctypes.byref(h), n, w)
    assert abs(np.corrcoef(z, w)[0, 1]) < 5 / np.sqrt(n)


# -- the sensors: a ctypes suite with SensorSuite's interface ------------------------------------
def flatten(x) -> np.ndarray:
    return np.concatenate([np.asarray(x[g], dtype=float).ravel() for g in SIGNALS])


def unflatten(v, n) -> dict:
    sizes = {"A": 9, "q": n, "qd": n, "qdd": n}
    out, k = {}, 0
    for g in SIGNALS:
        m = sizes.get(g, 3)
        out[g] = v[k:k + m].reshape(3, 3) if g == "A" else v[k:k + m]
        k += m
    return out


class CSuite:
    """The C sensor suite behind SensorSuite's interface (samples as dicts)."""

    def __init__(self, lib, n_joints, params=None, scale=1.0, seed=0, delay=0, imu=True, dt=DT):
        p = default_parameters()
        p.update(params or {})
        names = [lib.sr_sensors_parameter_name(i).decode() for i in range(len(p))]
        self.noise = np.array([p[nm[len("noise."):]] for nm in names])
        self.lib, self.n = lib, n_joints
        self.model = ctypes.create_string_buffer(lib.sr_sensors_model_size())
        self.state = State()
        assert ctypes.sizeof(self.state) == lib.sr_sensors_state_size()
        msg = ctypes.create_string_buffer(200)
        if lib.sr_sensors_init(self.model, n_joints, self.noise, scale, seed, delay, int(imu),
                               dt, msg, 200):
            raise ValueError(msg.value.decode())
        assert lib.sr_sensors_start(self.model, ctypes.byref(self.state)) == 0

    def measure(self, x):
        y = np.empty(24 + 3 * self.n + 12)
        assert self.lib.sr_sensors_measure(self.model, ctypes.byref(self.state), flatten(x), y) == 0
        return unflatten(y, self.n)

    def advance(self, x, dt):
        assert self.lib.sr_sensors_advance(self.model, ctypes.byref(self.state), flatten(x), dt) == 0

    def update(self, x, dt):
        y = np.empty(24 + 3 * self.n + 12)
        assert self.lib.sr_sensors_update(self.model, ctypes.byref(self.state), flatten(x), dt, y) == 0
        return unflatten(y, self.n)

    def run(self, x, n, dt=DT):
        """run() of the constant sample x without the per-call dict conversions."""
        xf, Y = flatten(x), np.empty((n, 24 + 3 * self.n + 12))
        update = self.lib["sr_sensors_update"]          # a raw handle: plain pointers, fast
        update.restype, update.argtypes = c_int, None
        args = (ctypes.c_void_p(ctypes.addressof(self.model)), ctypes.byref(self.state),
                ctypes.c_void_p(xf.ctypes.data), c_double(dt))
        for k in range(n):
            assert update(*args, ctypes.c_void_p(Y[k].ctypes.data)) == 0
        out, j = {}, 0
        for g in SIGNALS:
            m = {"A": 9, "q": self.n, "qd": self.n, "qdd": self.n}.get(g, 3)
            out[g] = Y[:, j:j + m].reshape(n, 3, 3) if g == "A" else Y[:, j:j + m]
            j += m
        return out


def run(suite, x, n, dt=DT):
    if isinstance(suite, CSuite):
        return suite.run(x, n, dt)
    ys = [suite.update(x, dt) for _ in range(n)]
    return {g: np.array([y[g] for y in ys]) for g in SIGNALS}


def same_sd(a, b, expected, m, k=5.0, mb=None):
    """Sample standard deviations a, b of m (b: mb) normals agree with each other and with
    the expected value within k standard errors (sd / sqrt(2 m) each)."""
    sa, sb = expected / np.sqrt(2 * m), expected / np.sqrt(2 * (mb or m))
    return (abs(a - b) <= k * np.hypot(sa, sb) and abs(a - expected) <= k * sa
            and abs(b - expected) <= k * sb)


def same_mean(a, b, sd, m, k=5.0, mb=None):
    """Sample means a, b of m (b: mb) draws of zero mean and standard deviation sd agree
    with each other and with 0 within k standard errors (sd / sqrt(m) each)."""
    sa, sb = sd / np.sqrt(m), sd / np.sqrt(mb or m)
    return abs(a - b) <= k * np.hypot(sa, sb) and abs(a) <= k * sa and abs(b) <= k * sb


def test_parameter_names_are_the_interface_table(lib):
    names = [lib.sr_sensors_parameter_name(i).decode() for i in range(len(NOISE_PARAMETERS) - 1)]
    assert names == [k for k in NOISE_PARAMETERS if k != "noise.scale"]
    assert lib.sr_sensors_parameter_name(len(names)) is None
    assert lib.sr_sensors_parameter_name(-1) is None


def test_bad_parameters_are_refused_naming_the_fmu_parameter(lib):
    ok = np.array([default_parameters()[k[len("noise."):]] for k in NOISE_PARAMETERS
                   if k != "noise.scale"])
    model = ctypes.create_string_buffer(lib.sr_sensors_model_size())
    msg = ctypes.create_string_buffer(200)

    def refused(n=N_JOINTS, noise=ok, scale=1.0, seed=0, delay=0, imu=1, dt=DT, size=200):
        status = lib.sr_sensors_init(model, n, np.ascontiguousarray(noise, float), scale, seed,
                                     delay, imu, dt, msg, size)
        return status == 1 and msg.value.decode()

    assert lib.sr_sensors_init(model, N_JOINTS, ok, 1.0, 0, 0, 1, DT, msg, 200) == 0
    for i in range(len(ok)):
        name = lib.sr_sensors_parameter_name(i).decode()
        for bad in (-1e-9, np.nan, np.inf):
            noise = ok.copy()
            noise[i] = bad
            assert name in refused(noise=noise), (name, bad)
    for bad in (-1.0, np.nan, np.inf):
        assert "noise.scale" in refused(scale=bad)
    assert "noise.scale" in refused(scale=1e300, noise=ok * 0 + 1e300)
    assert "noise.delay" in refused(delay=-1) and "noise.delay" in refused(delay=MAX_DELAY + 1)
    assert "noise.imu" in refused(imu=2) and "noise.imu" in refused(imu=-1)
    assert "seed" in refused(seed=-1)
    assert "joints" in refused(n=0) and "joints" in refused(n=MAX_JOINTS + 1)
    for bad in (0.0, -0.1, np.nan):
        assert "step" in refused(dt=bad)
    assert refused(imu=2, size=5) == "nois"                     # truncated, NUL-terminated
    # per-sample calls refuse bad steps and inconsistent states without touching anything
    s = CSuite(lib, N_JOINTS, delay=3)
    x = flatten(true_sample(np.random.default_rng(0)))
    y = np.full(x.size, 7.0)
    for bad in (0.0, -1.0, np.nan, np.inf):
        assert lib.sr_sensors_advance(s.model, ctypes.byref(s.state), x, bad) == 2
        assert lib.sr_sensors_update(s.model, ctypes.byref(s.state), x, bad, y) == 2
    before = bytes(s.state)
    for field, value in (("count", 4), ("count", -1), ("head", 3), ("head", -5)):
        st = State.from_buffer_copy(before)
        setattr(st, field, value)
        assert lib.sr_sensors_measure(s.model, ctypes.byref(st), x, y) == 3
        assert lib.sr_sensors_advance(s.model, ctypes.byref(st), x, DT) == 3
    assert np.all(y == 7.0) and bytes(s.state) == before


def test_scale_zero_passes_the_true_sample_on_bit_for_bit(lib):
    rng = np.random.default_rng(1)
    for delay in (0, 2):
        s = CSuite(lib, N_JOINTS, scale=0.0, seed=3, delay=delay)
        xs = [true_sample(rng) for _ in range(60)]
        xs[5]["qd"][2], xs[7]["H"][0], xs[9]["r_S"][1] = np.nan, np.inf, -np.inf
        for k, x in enumerate(xs):
            y = s.update(x, DT)
            src = xs[max(0, k - delay)]
            for g in SIGNALS:
                assert np.asarray(src[g]).tobytes() == np.asarray(y[g]).tobytes(), (k, g)


def test_no_imu_outputs_zero_accelerations(lib):
    x = true_sample(np.random.default_rng(14))
    for scale in (0.0, 1.0):
        y = CSuite(lib, N_JOINTS, scale=scale, imu=False).measure(x)
        assert not y["a_S"].any() and not y["alpha_B"].any()
        assert np.array_equal(y["omega_B"], x["omega_B"]) == (scale == 0.0)


def test_same_seed_same_run_other_seed_other_run(lib):
    rng = np.random.default_rng(2)
    xs = [true_sample(rng) for _ in range(30)]
    a, b, c = (CSuite(lib, N_JOINTS, seed=s) for s in (5, 5, 6))
    for k, x in enumerate(xs):
        ya, yb, yc = a.update(x, DT), b.update(x, DT), c.update(x, DT)
        for g in SIGNALS:
            assert ya[g].tobytes() == yb[g].tobytes()
            if g != "H" or k > 0:          # every channel noisy (H's error is 0 at the start)
                assert not np.array_equal(ya[g], yc[g]), (k, g)
    # one stream per sensor: another gyro magnitude leaves the other sensors' noise alone
    d, e = CSuite(lib, N_JOINTS, seed=5), CSuite(lib, N_JOINTS, {"gyro.arw": 1e-3}, seed=5)
    for x in xs:
        yd, ye = d.update(x, DT), e.update(x, DT)
        assert not np.array_equal(yd["omega_B"], ye["omega_B"])
        for g in SIGNALS:
            if g != "omega_B":
                assert np.array_equal(yd[g], ye[g]), g
    # the state is the whole run: a copy continues bit for bit
    saved = State.from_buffer_copy(bytes(a.state))
    y1 = [a.update(x, DT)["A"] for x in xs[:5]]
    ctypes.memmove(ctypes.byref(a.state), ctypes.byref(saved), ctypes.sizeof(saved))
    y2 = [a.update(x, DT)["A"] for x in xs[:5]]
    assert all(np.array_equal(p, q) for p, q in zip(y1, y2))


def test_measure_is_pure_and_update_is_measure_then_advance(lib):
    rng = np.random.default_rng(3)
    a, b = CSuite(lib, N_JOINTS, seed=9, delay=1), CSuite(lib, N_JOINTS, seed=9, delay=1)
    for _ in range(4):
        x = true_sample(rng)
        m1, m2 = a.measure(x), a.measure(x)
        y = b.update(x, DT)
        a.advance(x, DT)
        for g in SIGNALS:
            assert np.array_equal(m1[g], m2[g]) and np.array_equal(m1[g], y[g])


def test_delay_is_exactly_noise_delay_samples(lib):
    rng = np.random.default_rng(13)
    xs = [true_sample(rng) for _ in range(25)]
    for delay in (1, 3, 7):
        a, b = CSuite(lib, N_JOINTS, seed=9), CSuite(lib, N_JOINTS, seed=9, delay=delay)
        ya = [a.update(x, DT) for x in xs]
        yb = [b.update(x, DT) for x in xs]
        for k in range(len(xs)):
            for g in SIGNALS:
                assert np.array_equal(yb[k][g], ya[max(0, k - delay)][g]), (delay, k, g)
    # the longest delay: the ring wraps round several times
    a, b = CSuite(lib, 2, seed=1), CSuite(lib, 2, seed=1, delay=MAX_DELAY)
    xs = [np.random.default_rng(k).standard_normal(24 + 6 + 12) for k in range(350)]
    for x in xs:
        x[6:15] = np.eye(3).ravel()
    ya = [a.update(unflatten(x, 2), DT)["r_S"] for x in xs]
    yb = [b.update(unflatten(x, 2), DT)["r_S"] for x in xs]
    assert all(np.array_equal(yb[k], ya[max(0, k - MAX_DELAY)]) for k in range(len(xs)))


def test_quantisation_is_exact_nearest_step_ties_to_even(lib):
    rng = np.random.default_rng(11)
    x = true_sample(rng)
    for res in (1e-3, 1.1984e-5, 0.25):
        s = CSuite(lib, N_JOINTS, zero_except(**{"enc.resolution": res}), seed=7)
        qs = rng.uniform(-3, 3, (2000, N_JOINTS))
        if res == 0.25:                          # exact ties: k + 1/2 steps, binary exact
            qs[:, :] = (rng.integers(-12, 12, qs.shape) + 0.5) * res
        out = np.array([s.update(dict(x, q=q), DT)["q"] for q in qs])
        # NumPy's definition: res * round(q / res), round half to even (single IEEE operations)
        assert np.array_equal(out, res * np.round(qs / res))
        assert np.abs(out - qs).max() <= res / 2 * (1 + 1e-9)
        steps = out / res
        assert np.abs(steps - np.round(steps)).max() < 1e-9


def test_rotation_vector_to_matrix_against_scipy(lib):
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(4)
    R = np.empty(9)
    for angle in (0.0, 1e-12, 1e-9, 3e-8, 1e-5, 1e-3, 0.7, 3.0, 7.0):
        phi = angle * rng.standard_normal(3) / np.sqrt(3)
        lib.sr_rotation_vector_to_matrix(phi, R)
        M = R.reshape(3, 3)
        assert np.abs(M - Rotation.from_rotvec(phi).as_matrix()).max() < 2e-15, angle
        assert np.abs(M.T @ M - np.eye(3)).max() < 1e-15


# -- statistics against today's SensorSuite ----------------------------------------------------
@pytest.mark.slow
def test_white_noise_per_channel_equals_sensorsuite(lib):
    """Every white noise, one run each (m = 10000 samples): sd and mean per channel."""
    m = 10000
    x = true_sample(np.random.default_rng(5))
    x["A"] = np.eye(3)           # the star tracker's error rotation is then the output itself
    p = {"gyro.arw": 2e-4, "star.cross": 1e-4, "star.roll": 5e-4, "nav.r": 0.02,
         "nav.v": 3e-3, "accel.vrw": 1e-3, "alpha": 4e-4, "enc.q": 1e-4, "enc.qd": 2e-4,
         "enc.qdd": 2e-3}
    yc = run(CSuite(lib, N_JOINTS, zero_except(**p), seed=4), x, m)
    yp = run(SensorSuite(N_JOINTS, zero_except(**p), seed=4), x, m)
    expect = {"r_S": p["nav.r"], "v_S": p["nav.v"], "omega_B": p["gyro.arw"] / np.sqrt(DT),
              "a_S": p["accel.vrw"] / np.sqrt(DT), "alpha_B": p["alpha"], "q": p["enc.q"],
              "qd": p["enc.qd"], "qdd": p["enc.qdd"]}
    for g, sd in expect.items():
        ec, ep = yc[g] - x[g], yp[g] - x[g]
        for i in range(ec.shape[1]):
            assert same_sd(ec[:, i].std(), ep[:, i].std(), sd, m), (g, i, ec[:, i].std(), ep[:, i].std(), sd)
            assert same_mean(ec[:, i].mean(), ep[:, i].mean(), sd, m), (g, i)
    # star tracker: A_meas = exp([phi]x) (A = 1): a rotation; phi per axis (cross, cross, roll)
    for y in (yc, yp):
        A = y["A"]
        assert max(np.abs(a.T @ a - np.eye(3)).max() for a in A) < 1e-14
        assert np.all(np.linalg.det(A) > 0)
    phis = [np.stack([A[:, 2, 1], A[:, 0, 2], A[:, 1, 0]], axis=1) for A in (yc["A"], yp["A"])]
    for i, sd in enumerate((p["star.cross"], p["star.cross"], p["star.roll"])):
        assert same_sd(phis[0][:, i].std(), phis[1][:, i].std(), sd, m), i
        assert same_mean(phis[0][:, i].mean(), phis[1][:, i].mean(), sd, m), i


@pytest.mark.slow
def test_bias_random_walks_grow_as_sensorsuite(lib):
    """Gyro and accelerometer bias random walks over runs of 40 steps (initial bias 0; C 1000
    runs, Python 300): increments (m = runs x 40 x 3), Var(b(k)) = k d^2 dt at k = 10 and 40
    (m = runs x 3)."""
    runs, T = {"c": 1000, "py": 300}, 41
    rrw, brw = 3e-5, 1e-4
    x = true_sample(np.random.default_rng(6))
    p = zero_except(**{"gyro.rrw": rrw, "accel.brw": brw})
    b = {}
    for name, cls in (("c", lambda s: CSuite(lib, N_JOINTS, p, seed=s)),
                      ("py", lambda s: SensorSuite(N_JOINTS, p, seed=s))):
        y = [run(cls(s), x, T) for s in range(runs[name])]
        b[name] = {g: np.array([r[g] - x[g] for r in y]) for g in ("omega_B", "a_S")}  # (runs, T, 3)
    for g, d in (("omega_B", rrw), ("a_S", brw)):
        bc, bp = b["c"][g], b["py"][g]
        assert np.all(bc[:, 0] == 0.0) and np.all(bp[:, 0] == 0.0)
        ic, ip = np.diff(bc, axis=1), np.diff(bp, axis=1)
        assert same_sd(ic.std(), ip.std(), d * np.sqrt(DT), ic.size, mb=ip.size), g
        assert same_mean(ic.mean(), ip.mean(), d * np.sqrt(DT), ic.size, mb=ip.size), g
        for k in (10, 40):
            vc, vp, v = (bc[:, k] ** 2).mean(), (bp[:, k] ** 2).mean(), k * d * d * DT
            sc, sp = v * np.sqrt(2.0 / bc[:, k].size), v * np.sqrt(2.0 / bp[:, k].size)
            assert abs(vc - vp) <= 5 * np.hypot(sc, sp) and abs(vc - v) <= 5 * sc \
                and abs(vp - v) <= 5 * sp, (g, k, vc, vp, v)


def test_impulses_are_integrated_from_the_known_thrust(lib):
    rng = np.random.default_rng(12)
    s = CSuite(lib, N_JOINTS, zero_except(**{"thrust.scale": 0.05, "thrust.misalign": 0.02}),
               seed=8)
    x = true_sample(rng)
    x["J"], x["H"] = np.zeros(3), np.zeros(3)
    n = 25
    for k in range(n + 1):
        y = s.measure(x)
        if k == n:
            break
        s.advance(x, DT)
        x = dict(x, J=x["J"] + DT * x["F"], H=x["H"] + DT * (x["M"] + np.cross(x["r_S"], x["F"])))
    dF, dM = y["F"] - x["F"], y["M"] - x["M"]
    assert np.allclose(y["J"] - x["J"], n * DT * dF, rtol=1e-12, atol=1e-15)
    assert np.allclose(y["H"] - x["H"], n * DT * (dM + np.cross(x["r_S"], dF)), rtol=1e-10,
                       atol=1e-13)
    assert np.abs(dF).max() > 1e-4 * np.abs(x["F"]).max()
    # a non-finite sample adds nothing to the angular impulse error
    h = np.array(s.state.H_err)
    s.advance(dict(x, M=np.array([np.nan, 0.0, 0.0])), DT)
    assert np.array_equal(np.array(s.state.H_err), h)


# -- the same bits on Windows ------------------------------------------------------------------
PROGRAM = r"""
#include <stdio.h>
#include "rng.h"
#include "sensors.h"

static void hex(uint64_t v)
{
    int i;
    for (i = 60; i >= 0; i -= 4)
        putchar("0123456789abcdef"[(v >> i) & 15]);
    putchar('\n');
}

static void dhex(double x)
{
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    hex(b);
}

int main(void)
{
    const uint64_t st[4] = {1, 2, 3, 4};
    double noise[SR_NOISE_COUNT] = {2e-5, 4.8e-6, 2e-7, 9.7e-6, 4.8e-5, 0.01, 0.001, 5e-4,
                                    3e-3, 5e-6, 2e-4, 1.1984e-5, 5e-6, 1e-4, 1e-3, 0.02, 8.7e-3};
    static sr_sensors_state state;
    sr_sensors_model model;
    sr_rng g, in;
    double x[SR_SENSORS_ROW], y[SR_SENSORS_ROW], phi[3], s, c;
    int i, k, n = 6;
    sr_rng_set_state(&g, st);
    for (i = 0; i < 10; ++i)
        hex(sr_rng_next(&g));
    sr_rng_seed(&g, 42);
    for (i = 0; i < 2000; ++i)
        dhex(sr_rng_normal(&g));
    for (i = 0; i < 500; ++i) {
        const double u = sr_rng_uniform(&g);
        dhex(sr_portable_log(u * 1e3));
        sr_portable_sincos((u - 0.5) * 100.0, &s, &c);
        dhex(s);
        dhex(c);
    }
    noise[SR_NOISE_ENC_RESOLUTION] = 1e-3;          /* quantisation visible */
    if (sr_sensors_init(&model, n, noise, 3.0, 7, 2, 1, 0.1, NULL, 0) || sr_sensors_start(&model, &state))
        return 1;
    sr_rng_seed(&in, 99);
    for (k = 0; k < 300; ++k) {
        for (i = 0; i < SR_X_LEN(n); ++i)
            x[i] = sr_rng_normal(&in) * 10.0;
        for (i = 0; i < 3; ++i)
            phi[i] = sr_rng_normal(&in);
        sr_rotation_vector_to_matrix(phi, x + SR_X_A_B);
        if (sr_sensors_update(&model, &state, x, 0.1, y))
            return 2;
        for (i = 0; i < SR_X_LEN(n); ++i)
            dhex(y[i]);
    }
    return 0;
}
"""


@pytest.mark.slow
def test_mingw_build_under_wine_gives_the_same_bits(tmp_path, tmp_path_factory):
    mingw, cc = native_hosts.mingw(), native_hosts.c_compiler()
    if not (mingw and native_hosts.wine() and cc):
        pytest.skip("needs gcc, x86_64-w64-mingw32-gcc and wine (Debian: gcc-mingw-w64-x86-64 wine)")
    src = tmp_path / "prog.c"
    src.write_text("#include <string.h>\n" + PROGRAM)
    flags = ["-std=c99", "-O2", "-ffp-contract=off", "-Wall", "-Wextra", "-Werror", f"-I{SRC}"]
    files = [str(src), *(str(SRC / f) for f in SOURCES)]
    subprocess.run([cc, *flags, *files, "-o", str(tmp_path / "prog"), "-lm"], check=True)
    subprocess.run([mingw, *flags, *files, "-o", str(tmp_path / "prog.exe"), "-static-libgcc"],
                   check=True)
    native = subprocess.run([str(tmp_path / "prog")], capture_output=True, text=True, check=True).stdout
    res = native_hosts.run_wine(native_hosts.work_dir(tmp_path_factory), [tmp_path / "prog.exe"])
    assert res.returncode == 0, res.stderr[-2000:]
    windows = res.stdout
    lines = native.splitlines()
    assert len(lines) == 10 + 2000 + 1500 + 300 * (24 + 18 + 12)
    assert [int(v, 16) for v in lines[:3]] == [11520, 0, 1509978240]
    assert windows == native
