"""The rigid band's reference formulation (native/src/band.c; docs/identification.md, "The
rigid band"), written from the equations with NumPy and SciPy, no code shared with the band:
the reference information filter's rows (oracles.information, which takes the equations'
arrays and the thrust integrals from the library, never its filter or band) at one
linearisation point, the compliance columns of oracles.modal, scipy.signal's Butterworth
low-pass (from rest at the first sample's rows), and one batch least squares over the prior
and every filtered row from the low-pass's start on, compensated for the errors in
variables. benchmarks/modal_information.py and rigid_band.py take their rows from it too."""
from __future__ import annotations

import numpy as np

from .information import InformationFilter
from .modal import drive, filter_states, modal_columns

#: the low-pass's cut-off [Hz], order and start (its first SETTLE / FC s left out); the
#: compliance's filters [Hz, damping]; the chi2 drop that takes the compliance; each
#: compliance unknown's prior information
FC, ORDER, SETTLE = 0.15, 6, 3.0
QS = ((2.0, 0.7), (1.0, 0.7))
CHI2_DROP, PRIOR_INFO = 0.5, 1e-12


class RowsFilter(InformationFilter):
    """The reference filter, keeping each sample's whitened rows [W H | W y] and weight W
    (refreshed at every sample)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, refresh=1, **kw)
        self.rows_w, self.weights = [], []

    def add(self, t, x, z_lin=None):
        super().add(t, x, z_lin)               # the weight W of this sample: self.Wh
        x = np.ascontiguousarray(x, float)
        H, y = self.linear_rows(x)             # as add formed them (the same thrust sums)
        if self.nb:
            for i in range(3):
                xp = x.copy()
                xp[15 + i] += 1.0
                H[:, -3 + i] = -(self.rows_at(xp, z_lin) - self.rows_at(x, z_lin))
        self.rows_w.append(np.column_stack([self.Wh @ H, self.Wh @ y]))
        self.weights.append(self.Wh.copy())

    def unweighted(self):
        """(W (K, nr, nr), the unweighted rows [H | y] (K, nr, nu + 1)) of the kept samples."""
        W = np.array(self.weights)
        return W, np.einsum("kij,kjl->kil", np.linalg.inv(W), np.array(self.rows_w))


def low_pass(dt: float):
    """(second-order sections, white-noise gain, samples left out) of the band's low-pass for
    the sample time dt: scipy.signal.butter(ORDER, FC), the gain its impulse response's squares
    over 40 / FC s."""
    from scipy.signal import butter, sosfilt
    sos = butter(ORDER, FC, fs=1.0 / dt, output="sos")
    impulse = np.zeros(int(round(40.0 / FC / dt)))
    impulse[0] = 1.0
    return sos, float(np.sum(sosfilt(sos, impulse) ** 2)), int(round(SETTLE / FC / dt))


def compliance_columns(ts, X, rows, filters=QS, blocks: str = "GC") -> np.ndarray:
    """(K, nr, 57 or 165 per filter) the columns (``blocks``: G and C, or all four) of the
    filters (frequency [Hz], damping; the compliance's QS, or given modes) at rest at the first
    sample, driven by the samples' base motion, in the filter's rows (angular about the
    origin)."""
    u = np.array([drive(x[6:15].reshape(3, 3), x[18:21], x[21:24], x[15:18]) for x in X])
    sig = [{"A": x[6:15].reshape(3, 3), "omega_B": x[15:18], "v_S": x[3:6], "r_S": x[0:3]}
           for x in X]
    out = []
    for f, zeta in filters:
        st = filter_states(u, ts, 2.0 * np.pi * f, zeta)
        out.append(np.array([modal_columns(st[k, 0], st[k, 1], sig[k], np.zeros(3), blocks)[rows]
                             for k in range(len(X))]))
    return np.concatenate(out, axis=2)


def answer(o: RowsFilter, prior, rows, comp: float, nm: int):
    """The band's answer of the weighted filtered rows ``rows`` (k, nr, nm + nu + 1: [M | H |
    y]) over the prior (the filter's first [R d]) and the compliance's: (u (nu), bound of the
    reported parameters (20), chi2, dof, estimates (20)); ``comp`` times the filter's
    errors-in-variables sums taken off H's block."""
    nu = o.nu
    N = nm + nu
    A = rows.reshape(-1, N + 1)
    P = np.zeros((N, N + 1))
    P[:nm, :nm] = np.sqrt(PRIOR_INFO) * np.eye(nm)
    P[nm:, nm:N], P[nm:, N] = prior
    full = np.vstack([P, A])
    S, s = full[:, :N].T @ full[:, :N], full[:, :N].T @ full[:, N]
    S_raw = S.copy()
    S[nm:, nm:] -= comp * o.N_HH
    s[nm:] -= comp * o.N_Hy
    x = np.linalg.solve(S, s)
    res = A[:, :N] @ x - A[:, N]
    dof = len(res) - N
    o.cov = np.linalg.inv(S_raw)[nm:, nm:]
    est, bound = o.estimate(x[nm:])
    return x[nm:], bound, float(res @ res / dof), dof, est


def band(o: RowsFilter, prior, ts, X, dt: float, filters=QS, blocks: str = "GC") -> dict:
    """The band over the samples X (times ts) that the reference filter ``o`` has taken (its
    rows kept, its errors-in-variables sums over the samples from the low-pass's start on;
    ``prior`` its first (R, d)): {"lowpass": answer, "compliance": answer (all filters),
    "compliance1": answer (the first filter alone), "pick": the one taken (lowpass or
    compliance), "alt": the answer beside it (compliance1 beside compliance, compliance beside
    lowpass), "gain": the low-pass's white-noise gain}. ``filters``, ``blocks``: the
    compliance's (QS, G and C), or the found modes' band's (given modes, ascending; "GCDT")."""
    from scipy.signal import sosfilt
    W, Hu = o.unweighted()
    sos, gain, settle = low_pass(dt)
    Mu = compliance_columns(ts, X, o.rows, filters, blocks)
    R = np.concatenate([Mu, Hu], axis=2)
    Z = (sosfilt(sos, R - R[0], axis=0) + R[0])[settle:]
    nm = Mu.shape[2]
    weighted = np.einsum("kij,kjl->kil", W[settle:], Z)
    m1 = nm // len(filters)
    out = {"compliance": answer(o, prior, weighted, gain, nm),
           "compliance1": answer(o, prior, np.concatenate([weighted[:, :, :m1],
                                                           weighted[:, :, nm:]], axis=2),
                                 gain, m1),
           "lowpass": answer(o, prior, weighted[:, :, nm:], gain, 0), "gain": gain}
    out["pick"] = ("compliance" if out["compliance"][2] < CHI2_DROP * out["lowpass"][2]
                   else "lowpass")
    out["alt"] = "compliance1" if out["pick"] == "compliance" else "compliance"
    return out
