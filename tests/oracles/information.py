"""Test oracle: the information filter of the momentum equations and its Cramér-Rao bound
(issue #29), the NumPy formulation that native/src/information.c implements (docs/
identification.md, "The information filter and the bound"); moved here from the research
prototype benchmarks/information.py.

**Measurement model.** At every sample the momentum equations (eqs. 11/16, ``sr_equations``
of the native core, momentum form) hold exactly with three kinds of unknowns besides the 20
inertial parameters: the system's momentum at the thrust integrals' origin ``c0`` (one
constant per row), the thrust's scale-factor and misalignment errors ``c`` (8, force and
moment; ``sr_thrust_sensitivity``), and the gyro's bias (3). With the inertias taken about the
body frames' origins (``z_O``) every row is linear in the unknowns (the quadratic part of
``psi D(mu)`` is ``-phi P_AXES`` times ``c_i c_j / m``: the parallel-axis terms). The sensors'
white noise (navigation position and velocity, star tracker, gyro, joint angles and rates) is
propagated to first order through the rows at the linearisation point, plus the second-order
product of the position and velocity noise in the angular momentum about the origin: each
sample's row covariance ``R_k`` (refreshed every ``refresh`` samples).

**The bound.** The Fisher information ``sum_k H_k^T R_k^-1 H_k`` plus the priors (``P0`` on the
inertial parameters, the thrust errors' and the gyro bias' own), its inverse mapped to the
reported parameters (mass, centre of mass, inertia about the centre of mass) by the first-order
Jacobian of that map.

**The filter.** Weighted least squares in square-root information form (a dense QR of the
stacked ``[[R d]; [W H, W y]]`` per sample, LAPACK through NumPy), corrected to first order for
the noise in its regressors (errors in variables: ``u + S^-1 (N_HH u - N_Hy)``).

The native core is called only for the equations' arrays (``sr_equations``) and the thrust
integrals and sensitivities (``sr_thrust_integrals_add``, ``sr_thrust_sensitivity``): never the
native filter (``sr_info_*``) this oracle checks.
"""
from __future__ import annotations

import ctypes
import math
from typing import Mapping, Optional, Sequence

import numpy as np

P = ctypes.POINTER(ctypes.c_double)
S2P = (0, 3, 5, 1, 2, 4)              # reported I (Ixx Iyy Izz Ixy Ixz Iyz) -> I# (eq. 21)
SHARP = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _ptr(a: np.ndarray):
    return a.ctypes.data_as(P)


def z_of_reported(x: Sequence[float]) -> np.ndarray:
    z = np.zeros(20)
    for k in range(2):
        b = np.asarray(x[10 * k:10 * k + 10], float)
        z[4 * k] = b[0]
        z[4 * k + 1:4 * k + 4] = b[0] * b[1:4]
        for i in range(6):
            z[8 + 6 * k + S2P[i]] = b[4 + i]
    return z


def reported_of_z(z: np.ndarray) -> np.ndarray:
    x = np.zeros(20)
    for k in range(2):
        m = z[4 * k]
        x[10 * k] = m
        x[10 * k + 1:10 * k + 4] = z[4 * k + 1:4 * k + 4] / m
        for i in range(6):
            x[10 * k + 4 + i] = z[8 + 6 * k + S2P[i]]
    return x


#: I_O# - I_c# = P [c_i c_j / m] (parallel axes: m ([b]x^T [b]x) = (|c|^2 1 - c c^T) / m)
P_AXES = np.array([[0, 0, 0, 1, 0, 1], [0, -1, 0, 0, 0, 0], [0, 0, -1, 0, 0, 0],
                   [1, 0, 0, 0, 0, 1], [0, 0, 0, 0, -1, 0], [1, 0, 0, 1, 0, 0]], float)


def origin_of_com(z: np.ndarray) -> np.ndarray:
    """z_O = (mu, inertias about the body frames' origins) of z = (mu, inertias about the
    centres of mass): the unknowns the momentum rows are linear in."""
    zo = z.copy()
    D = D_of_mu(z[:8])
    for k in range(2):
        zo[8 + 6 * k:14 + 6 * k] += P_AXES @ D[10 * k + 4:10 * k + 10]
    return zo


def com_of_origin(zo: np.ndarray) -> np.ndarray:
    z = zo.copy()
    D = D_of_mu(zo[:8])
    for k in range(2):
        z[8 + 6 * k:14 + 6 * k] -= P_AXES @ D[10 * k + 4:10 * k + 10]
    return z


def D_of_mu(mu: np.ndarray) -> np.ndarray:
    """eq. 23 per body: [m, c, c_i c_j / m] (c = m b)."""
    out = []
    for k in range(2):
        m, c = mu[4 * k], mu[4 * k + 1:4 * k + 4]
        out += [m, *c, *(c[i] * c[j] / m for i, j in SHARP)]
    return np.array(out)


class InformationFilter:
    """The square-root information filter over u = [z_O, c0, c, b_gyro] for ``robot`` (a
    ``spacerobot.core.robot_record.SrRobot``) with per-sample noise ``sd`` = {channel group:
    sd} (``r``, ``v``, ``att`` (3,), ``omega``, ``q``, ``qd``), thrust-error prior sd
    ``sd_c`` (8), gyro-bias prior sd, the estimator's prior ``P0_mu``, ``P0_theta`` about
    the guesses ``z0`` (20). Its inverse information is the bound."""

    def __init__(self, lib, robot, n: int, planar: bool, sd: dict, sd_c, P0_mu, P0_theta, z0,
                 refresh: int = 10, sd_gyro_bias: float = 0.0):
        self.L, self.robot, self.n = lib, robot, n
        lib.sr_equations.argtypes = [ctypes.c_void_p, ctypes.c_int, P, P]
        lib.sr_thrust_integrals_add.argtypes = [P, ctypes.c_int, ctypes.c_double, P, P, P]
        lib.sr_thrust_sensitivity.argtypes = [ctypes.c_int, P, ctypes.c_int, P, P]
        self.zi = [i for i in range(8) if not planar or i % 4 < 3] + \
                  [8 + 6 * k + i for k in range(2) for i in range(6) if not planar or i == 5]
        self.rows = [0, 1, 5] if planar else list(range(6))
        self.sd, self.sd_c = sd, np.asarray(sd_c, float)
        self.z0 = np.asarray(z0, float)
        nz, nr = len(self.zi), len(self.rows)
        self.nb = 3 if sd_gyro_bias > 0 else 0
        self.nu = nz + nr + 8 + self.nb
        prior = np.zeros(self.nu)
        prior[:nz] = [1.0 / (P0_mu if i < 8 else P0_theta) for i in self.zi]
        prior[nz:nz + nr] = 1e-24
        prior[nz + nr:nz + nr + 8] = [1.0 / s ** 2 if s > 0 else 1e300 for s in self.sd_c]
        prior[nz + nr + 8:] = 1.0 / sd_gyro_bias ** 2 if self.nb else 0
        self.prior = np.diag(prior)
        self.u0 = np.zeros(self.nu)
        self.u0[:nz] = origin_of_com(self.z0)[self.zi]
        # the square-root information filter (Bierman): R_info u = d in least squares
        self.Rinfo = np.sqrt(self.prior)
        self.d = self.Rinfo @ self.u0
        self.K = np.zeros(25)
        self.samples, self.refresh = 0, refresh
        self.u = self.u0.copy()
        self.Wh = None
        self.eiv = False                 # accumulate the regressors' noise (errors in variables)
        self.N_HH = np.zeros((self.nu, self.nu))
        self.N_Hy = np.zeros(self.nu)

    def z(self) -> np.ndarray:
        """The estimate as z (inertias about the centres of mass)."""
        zo = origin_of_com(self.z0)
        zo[self.zi] = self.u[:len(self.zi)]
        return com_of_origin(zo)

    def rows_at(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        E = np.zeros((3, 42))
        x = np.ascontiguousarray(x, float)
        self.L.sr_equations(ctypes.byref(self.robot), 0, _ptr(x), _ptr(E))
        r = np.concatenate([E[:, :8] @ z[:8] - E[:, 8],
                            E[:, 9:21] @ z[8:] - E[:, 22:42] @ D_of_mu(z[:8]) - E[:, 21]])
        return r[self.rows]

    def linear_rows(self, x: np.ndarray):
        """``(H, y)``: the used rows are ``H u - y`` exactly (u = [z_O, c0, c]): linear rows
        ``A mu - b``, angular ``phi theta_O - psi_lin [m, c] - y`` (the quadratic part of
        psi D(mu) is ``-phi P_AXES`` times it: the inertias about the frames' origins absorb
        it), ``- c0 - S c``."""
        nz, nr = len(self.zi), len(self.rows)
        E = np.zeros((3, 42))
        x = np.ascontiguousarray(x, float)
        self.L.sr_equations(ctypes.byref(self.robot), 0, _ptr(x), _ptr(E))
        full = np.zeros((6, 20))
        full[:3, :8] = E[:, :8]
        for k in range(2):
            full[3:, 4 * k:4 * k + 4] = -E[:, 22 + 10 * k:26 + 10 * k]
        full[3:, 8:] = E[:, 9:21]
        yfull = np.concatenate([E[:, 8], E[:, 21]])
        H = np.zeros((nr, self.nu))
        H[:, :nz] = full[self.rows][:, self.zi]
        H[:, nz:nz + nr] = -np.eye(nr)
        S = np.zeros((3, 16))
        k = np.ascontiguousarray(self.K[10:])
        self.L.sr_thrust_sensitivity(0, _ptr(x), self.n, _ptr(k), _ptr(S))
        H[:, nz + nr:nz + nr + 8] = -np.vstack([S[:, :8], S[:, 8:]])[self.rows]
        # the unidentified z (planar) at their guesses move to the right-hand side
        rest = [i for i in range(20) if i not in self.zi]
        y = yfull[self.rows] - full[self.rows][:, rest] @ origin_of_com(self.z0)[rest]
        return H, y

    def noise_covariance(self, x: np.ndarray, z: np.ndarray) -> np.ndarray:
        n, nr = self.n, len(self.rows)
        R = np.zeros((nr, nr))
        chans = [(0, 3, self.sd["r"]), (3, 3, self.sd["v"]), (15, 3, self.sd["omega"]),
                 (24 + n, n, self.sd["qd"]), (24, n, self.sd["q"])]
        for at, count, sd in chans:
            for i in range(count):
                if sd == 0:
                    continue
                h = 1e-4
                xp, xm = x.copy(), x.copy()
                xp[at + i] += h
                xm[at + i] -= h
                g = (self.rows_at(xp, z) - self.rows_at(xm, z)) / (2 * h)
                R += sd ** 2 * np.outer(g, g)
        A = x[6:15].reshape(3, 3)
        for i, sd in enumerate(self.sd["att"]):
            if sd == 0:
                continue
            g = 0
            for sgn in (1, -1):
                w = np.zeros(3)
                w[i] = sgn * 1e-5
                th = np.linalg.norm(w)
                Kx = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]]) / th
                Rw = np.eye(3) + np.sin(th) * Kx + (1 - np.cos(th)) * Kx @ Kx
                xs = x.copy()
                xs[6:15] = (A @ Rw).ravel()
                g = g + sgn * self.rows_at(xs, z)
            g = g / 2e-5
            R += sd ** 2 * np.outer(g, g)
        # the navigation noises' product: the angular momentum about the inertial origin holds
        # M r_S x v_S (M the system's mass), so dr x M dv with dr, dv independent, isotropic:
        # covariance sd_r^2 sd_v^2 M^2 sum_ij (e_i x e_j)(e_i x e_j)^T = 2 sd_r^2 sd_v^2 M^2 I
        mass = z[0] + z[4] + sum(self.robot.link[k].m for k in range(n))
        ang = [a for a, row in enumerate(self.rows) if row >= 3]
        R[ang, ang] += 2.0 * (self.sd["r"] * self.sd["v"] * mass) ** 2
        return R

    def add(self, t: float, x: np.ndarray, z_lin: Optional[np.ndarray] = None) -> None:
        """Add the sample x at t, linearised at ``z_lin`` (20; default: the filter's own
        estimate)."""
        n = self.n
        x = np.ascontiguousarray(x, float)
        F, M, r = x[24 + 3 * n:27 + 3 * n].copy(), x[27 + 3 * n:30 + 3 * n].copy(), x[:3].copy()
        self.L.sr_thrust_integrals_add(_ptr(self.K), int(self.samples == 0), t, _ptr(r),
                                       _ptr(F), _ptr(M))
        z = self.z() if z_lin is None else np.asarray(z_lin, float)
        if self.samples % self.refresh == 0:
            R = self.noise_covariance(x, z)
            R += np.eye(len(R)) * 1e-12 * np.trace(R) / len(R)
            self.Wh = np.linalg.inv(np.linalg.cholesky(R))             # R^-1/2
        H, y = self.linear_rows(x)
        if self.nb:                      # the gyro's bias b: the rows read omega - b
            for i in range(3):
                xp = x.copy()
                xp[15 + i] += 1.0
                H[:, -3 + i] = -(self.rows_at(xp, z) - self.rows_at(x, z))
        Wh = self.Wh
        if self.eiv:
            self._add_eiv(x, Wh)
        stacked = np.vstack([np.column_stack([self.Rinfo, self.d]),
                             np.column_stack([Wh @ H, Wh @ y])])
        Rq = np.linalg.qr(stacked, mode="r")[:self.nu]
        self.Rinfo, self.d = Rq[:, :-1], Rq[:, -1]
        self.samples += 1
        if (self.samples - 1) % self.refresh == 0:
            self.solve()

    def _channels(self):
        n = self.n
        out = []
        for at, count, sd in [(0, 3, self.sd["r"]), (3, 3, self.sd["v"]), (15, 3, self.sd["omega"]),
                              (24 + n, n, self.sd["qd"]), (24, n, self.sd["q"])]:
            out += [(at + i, sd) for i in range(count) if sd > 0]
        return out

    def _add_eiv(self, x, Wh):
        """N += sum_l sigma_l^2 (dHw/dx_l)^T (dHw/dx_l) and the same with y: the expected share
        of the channels' white noise in the Gram matrices (Sagara-Wada)."""
        H0, y0 = self.linear_rows(x)
        for i, sd in self._channels():
            h = 1e-4 * max(1.0, abs(x[i]))
            xp = x.copy()
            xp[i] += h
            Hp, yp = self.linear_rows(xp)
            dH, dy = Wh @ (Hp - H0) / h, Wh @ (yp - y0) / h
            self.N_HH += sd ** 2 * dH.T @ dH
            self.N_Hy += sd ** 2 * dH.T @ dy
        # The slopes above are taken at the measured sample: the rows are bilinear in r_S and
        # v_S (M r_S x v_S), so the slope in r_S holds v_S's noise and the slope in v_S r_S's,
        # and the expected N counts the product's share sd_r^2 sd_v^2 |W d2H/dr_i dv_j|^2 twice
        # where the Gram holds it once: subtract it once.
        s2 = (self.sd["r"] * self.sd["v"]) ** 2
        if s2 > 0:
            def at(dr, dv):
                xs = x.copy()
                xs[0:3] += dr
                xs[3:6] += dv
                return self.linear_rows(xs)
            e = np.eye(3)
            for i in range(3):
                for j in range(3):
                    (Hrv, yrv), (Hr, yr), (Hv, yv) = at(e[i], e[j]), at(e[i], 0), at(0, e[j])
                    gH, gy = Wh @ (Hrv - Hr - Hv + H0), Wh @ (yrv - yr - yv + y0)
                    gH[:, len(self.zi):] = 0.0           # only z_O's columns carry the noise
                    self.N_HH -= s2 * gH.T @ gH
                    self.N_Hy -= s2 * gH.T @ gy

    def compensated(self) -> np.ndarray:
        """u corrected to first order for the regressors' noise: u + S^-1 (N_HH u - N_Hy)."""
        Ri = np.linalg.inv(self.Rinfo)
        return self.u + Ri @ Ri.T @ (self.N_HH @ self.u - self.N_Hy)

    def solve(self) -> None:
        self.u = np.linalg.solve(self.Rinfo, self.d)
        Ri = np.linalg.inv(self.Rinfo)
        self.cov = Ri @ Ri.T

    def estimate(self, u: Optional[np.ndarray] = None) -> tuple:
        """(reported parameters (20) of ``u`` (default: the filter's own, as of the last
        :meth:`solve`), their bound sd (20; 0 where not identified))."""
        nz = len(self.zi)
        u = self.u if u is None else np.asarray(u, float)
        zo = origin_of_com(self.z0)
        zo[self.zi] = u[:nz]

        def rep(v):
            w = zo.copy()
            w[self.zi] = v
            return reported_of_z(com_of_origin(w))
        x = rep(u[:nz])
        Jz = np.zeros((20, nz))
        for q in range(nz):
            h = 1e-6 * max(1.0, abs(u[q]))
            up, um = u[:nz].copy(), u[:nz].copy()
            up[q] += h
            um[q] -= h
            Jz[:, q] = (rep(up) - rep(um)) / (2 * h)
        C = Jz @ self.cov[:nz, :nz] @ Jz.T
        self.cov_reported = C
        sd = np.sqrt(np.maximum(np.diag(C), 0))
        sd[np.abs(Jz).sum(axis=1) == 0] = 0
        return x, sd

    def compensated_exact(self) -> np.ndarray:
        """u compensated exactly (bias-compensated least squares, Sagara-Wada): the solution
        of (S - N_HH) u_c = s - N_Hy, with S = R^T R, s = R^T d (solved by LAPACK as
        (1 - S^-1 N_HH) u_c = u - S^-1 N_Hy)."""
        Ri = np.linalg.inv(self.Rinfo)
        Si = Ri @ Ri.T
        return np.linalg.solve(np.eye(self.nu) - Si @ self.N_HH, self.u - Si @ self.N_Hy)

    def result(self, compensated) -> tuple:
        """(estimates (20; errors-in-variables compensated: 0 not, 1 (True) to first order,
        2 exactly), bound sd (20)) of the samples so far, as ``sr_info_estimate`` reports
        them; also sets ``cov_reported`` (20 x 20: the inverse information mapped to the
        reported parameters)."""
        self.solve()
        u = {0: self.u, 1: None, 2: None}.get(int(compensated))
        if int(compensated) == 1:
            u = self.compensated()
        elif int(compensated) == 2:
            u = self.compensated_exact()
        return self.estimate(u)


def sensor_noise(params: Mapping[str, float], dt: float, scale: float = 1.0) -> tuple:
    """``(sd, sd_c, sd_gyro_bias)`` of :class:`InformationFilter` for the sensor models'
    magnitudes ``params`` (names without ``noise.``, as ``spacerobot.sensors.
    default_parameters``) drawn every ``dt`` [s], all times ``scale``: densities ``d`` over
    1 s give ``d / sqrt(dt)`` per sample; the encoder's angle adds the uniform quantisation
    error of its resolution (variance ``res^2 / 12``)."""
    p, s = params, float(scale)
    sd = {"r": s * p["nav.r"], "v": s * p["nav.v"], "omega": s * p["gyro.arw"] / math.sqrt(dt),
          "qd": s * p["enc.qd"],
          "q": s * math.sqrt(p["enc.q"] ** 2 + p["enc.resolution"] ** 2 / 12),
          "att": [s * p["star.cross"], s * p["star.cross"], s * p["star.roll"]]}
    sd_c = [s * p["thrust.scale"], *[s * p["thrust.misalign"]] * 3] * 2
    return sd, sd_c, s * p["gyro.bias"]


def noise_vector(sd: Mapping, sd_c: Sequence[float], sd_gyro_bias: float) -> np.ndarray:
    """The 17 numbers of the native ``sr_info_noise`` (r, v, omega, att (3), q, qd, thrust (8),
    gyro_bias) of the same noise model."""
    return np.array([sd["r"], sd["v"], sd["omega"], *sd["att"], sd["q"], sd["qd"], *sd_c,
                     sd_gyro_bias], float)
