"""pythonfmu slave of the identifier: a thin wrapper mapping FMI variables to
spacerobot.estimator, whose Identifier runs the native C core through ctypes. It never imports
plant code: inside the FMU the library is bundled as ``_spacerobot_estimator`` with only the
robot description, the interface table, the arm geometry, the FMI base class, the core's ctypes
binding with the compiled library (``core/lib``) and the estimator (``fmi/build.py``'s
``BUNDLES``). The FMU state is the core's Data block (bytes).
"""
import math
import operator

import numpy as np

from _spacerobot_estimator.estimator.identifier import INPUT_LIMIT, KEYS, identifier_from_values
from _spacerobot_estimator.fmi.slave import InterfaceSlave, _escape
from _spacerobot_estimator.interface import EXCITE_SCORES, LAYOUT, STATUS, estimator_vars
from pythonfmu.enums import Fmi2Status


class SpaceRobotEstimator(InterfaceSlave):
    """Online one-step identification of base and target inertial parameters."""

    author = "spacerobot developers"
    description = ("Online one-step identification of the mass, centre of mass and inertia of "
                   "both the base and the captured target of a space robot, from measurements "
                   "alone (momentum- or force-based equations, modified RLS; Zhang, Yue, Yuan 2020).")
    version = "0.1.0"
    license = "MIT"

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self._setup(estimator_vars)
        self.ident = None
        self._inputs = [(n, v.key) for n, v in self.interface.items() if v.causality == "input"]
        self._input_names = [n for n, _ in self._inputs]
        # a sample: the inputs' values in one array, in the order of the identifier's KEYS
        # (each signal's elements row-major), as Identifier.update_flat takes it
        self._gather = _sample_layout(self._inputs, self.robot.n_joints)
        self._input_values = operator.itemgetter(*self._input_names)
        self.request = None
        # outputs: estimates and their standard deviations ("sd." + an estimate name), from
        # the identifier's report; scalars (attributes of the Identifier); the identified and
        # physical flags; the excitation request; the excitation diagnostics, computed when read
        outs = [(n, v.key) for n, v in self.interface.items() if v.causality == "output"]
        self._est_names = [n for n, k in outs if k[0] in _ESTIMATES]
        self._est_pos = np.array([LAYOUT.index(n) for n in self._est_names], dtype=int)
        self._sd_names = [n for n, k in outs if k[0] in _SDS]
        self._sd_pos = np.array([LAYOUT.index(n[len(_SD):]) for n in self._sd_names], dtype=int)
        self._scalar_outputs = [(n, k[0]) for n, k in outs if k[0] in _SCALAR_OUTPUTS]
        # a refresh at every step: both 20-vectors with one index, the scalars with one getter
        self._vec_names = self._est_names + self._sd_names
        self._vec_pos = np.concatenate([self._est_pos, len(LAYOUT.names) + self._sd_pos])
        self._scalar_names = [n for n, _ in self._scalar_outputs]
        get = operator.attrgetter(*(a for _, a in self._scalar_outputs))
        self._scalars = get if len(self._scalar_outputs) > 1 else (lambda x: (get(x),))
        self._flag_outputs = [(n, k) for n, k in outs if k[0] in _FLAGS]
        # the information filter's bound (crb.<estimate>) and the report's other scalars
        self._crb_names = [n for n, k in outs if k[0] in _CRBS]
        self._crb_pos = np.array([LAYOUT.index(n[len(_CRB):]) for n in self._crb_names],
                                 dtype=int)
        self._report_outputs = [(n, k) for n, k in outs if k[0] in _REPORT]
        self._lazy_outputs = {n: None for n, k in outs if k[0] in _LAZY}

    def _initialise(self) -> None:
        v = self.values
        try:
            self.ident, self.request = identifier_from_values(self.robot, v)
        except ValueError as e:
            self._fail(f"invalid estimator parameters: {e}")
        self._refresh()

    def _refresh(self) -> None:
        ident = self.ident
        rep = ident.report()
        o = dict(zip(self._vec_names,
                     np.concatenate((rep.vector, rep.std)).take(self._vec_pos).tolist()))
        o.update(zip(self._scalar_names, self._scalars(ident)))
        for name, (kind, who) in self._flag_outputs:
            o[name] = int(getattr(rep, kind)[who])
        o[_EXCITE] = self.request(rep.identified)
        o.update(zip(self._crb_names, rep.crb.take(self._crb_pos).tolist()))
        for name, key in self._report_outputs:
            val = getattr(rep, key[0])
            o[name] = float(val if len(key) == 1 else val[_REPORT[key[0]].index(key[1])])
        o.update(self._lazy_outputs)
        self._outputs = o

    def _get_output(self, name: str):
        self._ensure_current()
        key = self.interface[name].key[0]
        if key in _LAZY:
            if self.ident is None:
                return 0.0
            return self.ident.excitation()[_LAZY.index(key)]
        return self._outputs.get(name, 0)

    def do_step(self, current_time: float, step_size: float) -> bool:
        if not self._check_step(current_time, step_size, math.inf):
            return False
        x = np.array(self._input_values(self.values), dtype=float).take(self._gather)
        status = self.ident.update_flat(current_time, x)  # never raises; undoes a bad update
        self._refresh()
        if status in (3, 4):
            # name the FMI inputs at fault, not only the core's signal name
            bad = [n for n in self._input_names if not abs(float(self.values[n])) <= INPUT_LIMIT]
            where = f" [input {', '.join(bad)}]" if bad else ""
            self.log(_escape(f"t = {current_time:.6g} s: sample skipped ({STATUS[status]}){where}: "
                             f"{self.ident.message}; estimates unchanged"), Fmi2Status.warning)
        return True

    def _core_state(self):
        return None if self.ident is None else self.ident.get_state()

    def _restore_core_state(self, core) -> None:
        if core is None:
            self.ident = None
            return
        if self.ident is None:
            self._initialise()
        self.ident.set_state(core)
        self._refresh()


#: outputs that are attributes of the Identifier of the same name
_SCALAR_OUTPUTS = ("samples", "rejected", "status", "residual_lin", "residual_ang")
#: key groups of the estimate outputs and of their standard deviations (``sd.<estimate>``)
_ESTIMATES = ("est_base", "est_target")
_SDS = ("sd_base", "sd_target")
_SD = "sd."
#: per-body 0/1 outputs: key (Report attribute, body)
_FLAGS = ("identified", "physical")
#: the excitation request output
_EXCITE = "ident.excite"
#: the information filter's bound outputs (``crb.<estimate>``)
_CRBS = ("crb_base", "crb_target")
_CRB = "crb."
#: report scalars (Report attribute: element names of a vector attribute)
_REPORT = {"info_chi2": (), "excite_rate": (), "excite_score": EXCITE_SCORES}
#: outputs computed when read: the excitation diagnostics (mu, theta)
_LAZY = ("excitation_mu", "excitation_theta")


def _sample_layout(inputs, n: int) -> np.ndarray:
    """``gather``: ``x[gather]`` puts the values of the FMI ``inputs`` (in their order) into
    the order of the identifier's :data:`KEYS` (each signal's elements row-major), the flat
    sample of ``Identifier.update_flat``, with one index."""
    shapes = {"A": (3, 3), "q": (n,), "qd": (n,), "qdd": (n,)}
    where = {}
    for pos, (_, (group, idx)) in enumerate(inputs):
        shape = shapes.get(group, (3,))
        flat = idx[0] * shape[1] + idx[1] if group == "A" else idx
        where[(group, flat)] = pos
    gather = []
    for key in KEYS:
        gather += [where[(key, k)] for k in range(int(np.prod(shapes.get(key, (3,)))))]
    return np.array(gather, dtype=np.intp)
