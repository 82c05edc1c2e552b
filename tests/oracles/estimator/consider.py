"""Consider covariance: what constant thrust-knowledge errors, which the data cannot reveal,
add to the estimates' uncertainty (docs/identification.md, section 6).

The estimator knows the thrust only as commanded. A scale factor error ``s`` and a
misalignment ``phi`` (a small rotation), constant over a run, turn every measured force and
moment into ``(1 + s) R(phi) x``, ``x + (s + [phi]x) x`` to first order; the impulses follow
(``J`` exactly, ``H`` through its integral). They are not estimable: a thrust 2 % too large
looks like bodies 2 % heavier. The residual scatter therefore never shows them, and a
standard deviation built from the scatter alone shrinks below the error they leave. The
classical remedy (Schmidt's consider parameters; Tapley, Schutz and Born, *Statistical Orbit
Determination*, 2004, section 6.3) keeps their sensitivity instead:

    c = [s_F, phi_F (3), s_M, phi_M (3)]   (8 consider parameters, prior sd sigma_c)

    d rhs_k / d c = R_k   (per sample: the rows' right-hand sides, b and y, per parameter)
    d z / d c = G^-1 sum_k w_k H_k^T R_k    (the least-squares answer's sensitivity)
    sd_consider_i^2 = sum_c (J dz/dc)_ic^2 sigma_c^2

with ``G`` the information, ``H_k`` the rows and ``w_k`` their forgetting weights, as the
solver keeps them (:meth:`.ParameterSolver.consider_shift`), and ``J`` the Jacobian of the
reported estimates. The right-hand-side sensitivities of one sample, in the frame the thrust is
given in (inertial; a misalignment rotates it there, as :mod:`spacerobot.sensors` models it):

* force form (moments about the base origin S, where the thrust acts):
  ``db/ds_F = F``, ``db/dphi_F = -[F]x``, ``dy/ds_M = M``, ``dy/dphi_M = -[M]x``;
* momentum form (``J = int F dt``, ``H = int (M + r_S x F) dt``):
  ``db/ds_F = J``, ``db/dphi_F = -[J]x``, ``dy/ds_F = int r_S x F dt``,
  ``dy/dphi_F = -int [r_S]x [F]x dt``, ``dy/ds_M = int M dt``, ``dy/dphi_M = -[int M dt]x``.
  The integrals are not measured; :class:`ThrustIntegrals` accumulates them from the samples
  with the thrust held over each sample interval.

The identifier carries these sensitivities as extra right-hand-side columns of its equation
array, so that every linear step of its equations (differencing against a reference or a
window, the moving point, the row weights, the planar selection) treats them as the
right-hand sides they perturb.
"""
from __future__ import annotations

from typing import NamedTuple, Tuple

import numpy as np

__all__ = ["N_CONSIDER", "ThrustIntegrals", "thrust_sensitivity", "thrust_sd", "consider_sd", "skew"]

#: consider parameters: thrust force scale, its misalignment (3), moment scale, misalignment (3)
N_CONSIDER = 8


def skew(v: np.ndarray) -> np.ndarray:
    """``[v]x`` (3, 3): ``[v]x u = v x u``."""
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


class ThrustIntegrals(NamedTuple):
    """The thrust integrals the momentum form's sensitivities need, from the samples, the
    thrust of each sample held until the next (as the sensors model integrates its error).

    Immutable: :meth:`add` returns the updated one (an identifier's snapshot is a reference).

    Attributes
    ----------
    t : time of the last sample [s] (NaN before the first)
    r_S, F, M : (3,) its base position [m], force [N] and moment [N.m] (held forward)
    k_s : (3,) ``int r_S x F dt`` [N.m.s]
    k_phi : (3, 3) ``-int [r_S]x [F]x dt`` [N.m.s] (column i: the angular impulse of ``e_i x F``)
    k_M : (3,) ``int M dt`` [N.m.s]
    """

    t: float = float("nan")
    r_S: np.ndarray = np.zeros(3)
    F: np.ndarray = np.zeros(3)
    M: np.ndarray = np.zeros(3)
    k_s: np.ndarray = np.zeros(3)
    k_phi: np.ndarray = np.zeros((3, 3))
    k_M: np.ndarray = np.zeros(3)

    def add(self, t: float, r_S: np.ndarray, F: np.ndarray, M: np.ndarray) -> "ThrustIntegrals":
        """With the sample of time ``t`` [s]: the previous sample's thrust integrated over
        ``t - t_previous``, this sample's held from now on."""
        r_S, F, M = (np.array(v, dtype=float) for v in (r_S, F, M))
        if not self.t == self.t:                      # the first sample: nothing integrated
            return ThrustIntegrals(float(t), r_S, F, M, self.k_s, self.k_phi, self.k_M)
        dt = float(t) - self.t
        Rx = skew(self.r_S)
        return ThrustIntegrals(
            float(t), r_S, F, M,
            self.k_s + dt * (Rx @ self.F),                      # int r_S x F dt
            self.k_phi - dt * (Rx @ skew(self.F)),              # -int [r_S]x [F]x dt
            self.k_M + dt * self.M)                             # int M dt


def thrust_sensitivity(force: bool, F: np.ndarray, M: np.ndarray, J: np.ndarray,
                       K: ThrustIntegrals | None, out: np.ndarray) -> None:
    """The right-hand sides' sensitivities to the consider parameters of one sample, in place
    (module docstring).

    Parameters
    ----------
    force : the force form (else the momentum form)
    F, M : (3,) measured force [N] and moment [N.m];  J : (3,) linear impulse [N.s]
    K : the thrust integrals up to this sample (momentum form; unused by the force form)
    out : (3, 2 N_CONSIDER) written: columns ``0..7`` ``d b / d c``, ``8..15`` ``d y / d c``
    """
    n = N_CONSIDER
    out[:] = 0.0
    if force:
        out[:, 0], out[:, 1:4] = F, -skew(F)                    # b = F - F_arm
        out[:, n + 4], out[:, n + 5:n + 8] = M, -skew(M)        # y = M - M_arm,S
    else:
        out[:, 0], out[:, 1:4] = J, -skew(J)                    # b = J - P_arm
        out[:, n], out[:, n + 1:n + 4] = K.k_s, K.k_phi         # y = H - L_arm
        out[:, n + 4], out[:, n + 5:n + 8] = K.k_M, -skew(K.k_M)


def consider_sd(jac: np.ndarray, dz_dc: np.ndarray, sd_c: np.ndarray) -> np.ndarray:
    """``sqrt(sum_c (J dz/dc)_ic^2 sigma_c^2)`` (p,).

    Parameters
    ----------
    jac : (p, q) Jacobian of the reported estimates in the solver's parameters ``z``
    dz_dc : (q, N_CONSIDER) the solver's sensitivity (:meth:`.ParameterSolver.consider_shift`)
    sd_c : (N_CONSIDER,) prior standard deviations of the consider parameters
    """
    dx = jac @ (dz_dc * sd_c)                    # (p, 8): each parameter's shift at 1 sigma
    return np.sqrt(np.einsum("ij,ij->i", dx, dx))


def thrust_sd(scale: float, misalign: float) -> Tuple[np.ndarray, bool]:
    """The prior sd of the 8 consider parameters from the thrust's scale factor sd [1] and
    misalignment sd per axis [rad], the same for force and moment; and whether any is > 0."""
    sd = np.array([scale, misalign, misalign, misalign] * 2, dtype=float)
    return sd, bool(np.any(sd > 0.0))
