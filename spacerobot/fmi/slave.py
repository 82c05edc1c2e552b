"""Shared machinery of the two pythonfmu slaves: variables from the interface table, units and
InitialUnknowns in the model description, lifecycle checks, full state get/set/serialise.

pythonfmu 0.7.0 maps any Python exception to ``fmi2Fatal`` and ``do_step() -> False`` to
``fmi2Discard``. Invalid parameters, calls out of lifecycle order and invalid value references
raise :class:`FmiError` after logging their message; the FMU's front library turns those into
``fmi2Error`` (:mod:`.pythonfmu_compat`). A step that cannot be completed returns Discard with
the state as before the step.
"""
from __future__ import annotations

import copy
import json
import math
import operator
import os
import pickle
from typing import Dict, List

from pythonfmu import Boolean, Fmi2Slave, Integer, Real, String
from pythonfmu.enums import Fmi2Causality, Fmi2Status, Fmi2Variability
from xml.etree.ElementTree import Element, SubElement

from ..interface import UNITS, Var, body_of
from ..robots import RigidBody, scenario_from_dict
from .pythonfmu_compat import binary_hooks, guard_entry_points

CONFIG_FILE = "spacerobot_config.json"
#: largest number of cached value-reference lists of get_real / set_real (InterfaceSlave._plan)
_MAX_PLANS = 256


def _escape(msg: str) -> str:
    """FMI loggers treat the message as a printf format: escape '%'."""
    return msg.replace("%", "%%")


def _plan_key(kind: str, vrs) -> tuple:
    """The key of a value-reference list's plan: its kind, length and ends."""
    return (kind, len(vrs), vrs[0], vrs[-1]) if vrs else (kind, 0)


def _merged_getter(names, is_output):
    """``get(outputs, values)``: the tuple of the values of ``names`` (k,) in their order, those
    with ``is_output`` (k,) from the dictionary ``outputs``, the others from ``values``, in a
    few C-level calls (``operator.itemgetter``); KeyError if one is missing. Where the names
    of each kind are contiguous (e.g. a recorder's connectors, then the outputs) the two
    tuples are joined as they are; otherwise reordered by one more getter."""
    out = [n for n, o in zip(names, is_output) if o]
    val = [n for n, o in zip(names, is_output) if not o]

    def getter(keys):
        if not keys:
            return lambda d: ()
        g = operator.itemgetter(*keys)
        return g if len(keys) > 1 else (lambda d: (g(d),))

    get_out, get_val = getter(out), getter(val)
    if not val:
        return lambda outputs, values: get_out(outputs)
    if not out:
        return lambda outputs, values: get_val(values)
    flips = sum(a != b for a, b in zip(is_output, is_output[1:]))
    if flips == 1:                                  # two runs: one join, no reordering
        if is_output[0]:
            return lambda outputs, values: get_out(outputs) + get_val(values)
        return lambda outputs, values: get_val(values) + get_out(outputs)
    # position of each name in get_out(outputs) + get_val(values)
    where = {n: i for i, n in enumerate(out)}
    where.update((n, len(out) + i) for i, n in enumerate(val))
    order = operator.itemgetter(*(where[n] for n in names))
    return lambda outputs, values: order(get_out(outputs) + get_val(values))


class FmiError(ValueError):
    """A call refused with a logged message and the state unchanged: ``fmi2Error`` (with
    pythonfmu's stock binary, which cannot return it, ``fmi2Fatal``)."""


class InterfaceSlave(Fmi2Slave):
    """Base class: registers :class:`~spacerobot.interface.Var` rows as FMI variables.

    Subclasses provide ``_outputs`` (name -> value, refreshed by the subclass) and implement
    ``_core_state``/``_restore_core_state`` and ``do_step``.
    """

    #: outputs computed when read (name -> None; None in ``_outputs``, ``_get_output`` computes
    #: them); a subclass that has such outputs names them before the first value is read
    _lazy_outputs: Dict[str, None] = {}

    def _setup(self, variables_of) -> None:
        """Load the bundled scenario and register ``variables_of(robot, scenario)``."""
        from pythonfmu import DefaultExperiment

        with open(os.path.join(self.resources or ".", CONFIG_FILE)) as f:
            self.scenario = scenario_from_dict(json.load(f)["scenario"])
        self.robot = self.scenario.robot
        self.default_experiment = DefaultExperiment(0.0, self.scenario.stop_time,
                                                    self.scenario.sample_time)
        self._hooks = binary_hooks(self.resources, type(self).__name__)
        self._hooks.guard_exit()
        self._register_interface(variables_of(self.robot, self.scenario))

    def _body(self, prefix: str) -> RigidBody:
        """The rigid body held in parameters ``<prefix>.m``, ``.b[1..3]``, ``.Ixx`` ...
        (:func:`spacerobot.interface.body_of`)."""
        return body_of(self.values, prefix)

    def _register_interface(self, variables: List[Var]) -> None:
        self.interface: Dict[str, Var] = {v.name: v for v in variables}
        self.values: Dict[str, float] = {}
        self._outputs: Dict[str, float] = {}
        self.phase = "instantiated"
        self._dirty = True          # parameters changed since the outputs were computed
        guard_entry_points(self, self._hooks, (FmiError,))
        for var in variables:
            cls = Real if var.type == "Real" else Integer
            kw = dict(causality=getattr(Fmi2Causality, var.causality),
                      variability=getattr(Fmi2Variability, var.variability),
                      description=var.description)
            if var.causality in ("parameter", "input"):
                self.values[var.name] = var.start
                kw["setter"] = (lambda x, n=var.name: self._set(n, x))
                kw["getter"] = (lambda n=var.name: self.values[n])
            else:
                kw["getter"] = (lambda n=var.name: self._get_output(n))
                kw["setter"] = (lambda x, n=var.name: self._fail(
                    f"{n} is an output and cannot be set (tried to set {x!r})"))
            self.register_variable(cls(var.name, **kw), nested=False)
        # fast paths of get_real / set_real (see there): value reference -> name
        self._real_vr = {v.value_reference: v.name for v in self.vars.values()
                         if isinstance(v, Real)}
        self._input_vr = {vr: n for vr, n in self._real_vr.items()
                          if self.interface[n].causality == "input"}
        self._plans: Dict[tuple, object] = {}     # fast paths of get_real / set_real

    # -- fast paths: pythonfmu calls a getter/setter closure per variable; a master reads and
    # writes the same connectors and outputs at every step, so for each list of value
    # references seen, the names are looked up once and the values then moved between the
    # dictionaries and the FMI call with C-level operations (same values, same checks) ---------
    def get_real(self, vrs):
        self._ensure_current()
        plan = self._cached("get", vrs)
        if plan is None:
            plan = self._plan("get", vrs)
        if plan:
            get, names, lazy = plan
            try:
                vals = get(self._outputs, self.values)
            except KeyError:                      # not (yet) among the outputs
                vals = None
            if vals is not None:
                vals = list(vals)                 # numbers: pythonfmu takes PyFloat_AsDouble
                for i in lazy:                    # outputs computed when read
                    vals[i] = self._get_output(names[i])
                return vals
        names, outs, values = self._real_vr, self._outputs, self.values
        res = []
        for vr in vrs:
            name = names[vr]
            x = outs.get(name)
            if x is None:                         # input/parameter, or computed when read
                x = values[name] if name in values else self._get_output(name)
            res.append(float(x))
        return res

    def set_real(self, vrs, values):
        plan = self._cached("set", vrs)
        if plan is None:
            plan = self._plan("set", vrs)
        if plan:                                  # every one an input: stored as it comes
            self.values.update(zip(plan, values))
            return
        inputs, store = self._input_vr, self.values
        for vr, x in zip(vrs, values):
            name = inputs.get(vr)
            if name is None:                      # parameters (checked), outputs, other types
                self._check_refs("setReal", [vr], Real)
                super().set_real([vr], [x])
            else:
                store[name] = x

    def _plan(self, kind: str, vrs):
        """The fast path of ``get_real`` / ``set_real`` for this list of value references
        (cached); ``()`` when the per-variable path must be taken. Refuses (fmi2Error) unknown
        value references and variables of another type.

        ``get``: ``(get, names, lazy)``, ``get(outputs, values)`` the tuple of the values in
        the order asked for, outputs from ``_outputs``, inputs and parameters from ``values``
        (a recorder asks for both at once); ``lazy`` the positions of the outputs computed when
        read (:attr:`_lazy_outputs`, None in ``_outputs``). ``set``: the tuple of names, when
        every one is an input."""
        self._check_refs("getReal" if kind == "get" else "setReal", vrs, Real)
        names = tuple(self._real_vr[vr] for vr in vrs)
        plan = ()
        if kind == "get" and names:
            plan = (_merged_getter(names, [self.interface[n].causality == "output"
                                           for n in names]), names,
                    tuple(i for i, n in enumerate(names) if n in self._lazy_outputs))
        elif kind == "set" and names and all(vr in self._input_vr for vr in vrs):
            plan = names
        return self._store(kind, vrs, plan)

    def _cached(self, kind: str, vrs):
        """The plan stored for exactly this list of value references, or None. Keyed by the
        list's length and ends (a tuple of every reference would be built and hashed at every
        call), the whole list compared (C-level) before use."""
        entry = self._plans.get(_plan_key(kind, vrs))
        return entry[1] if entry is not None and entry[0] == vrs else None

    def _store(self, kind: str, vrs, plan):
        if len(self._plans) >= _MAX_PLANS:      # a host that keeps asking for new lists
            self._plans.clear()
        self._plans[_plan_key(kind, vrs)] = (vrs[:], plan)    # a copy of the same type
        return plan

    def _check_refs(self, call: str, vrs, cls) -> None:
        """Refuse (fmi2Error) unknown value references and variables of another type."""
        for vr in vrs:
            var = self.vars.get(vr)
            if var is None:
                self._fail(f"fmi2{call[0].upper()}{call[1:]}: unknown value reference {vr}")
            if not isinstance(var, cls):
                self._fail(f"fmi2{call[0].upper()}{call[1:]}: {var.name} (value reference {vr}) "
                           f"is not of type {cls.__name__}")

    def get_integer(self, vrs):
        # fast path as get_real's (the identifier's counters and flags are recorded at every
        # step): outputs from ``_outputs``, parameters and inputs from ``values``, as their
        # getters return them
        plan = self._cached("geti", vrs)
        if plan is None:
            self._check_refs("getInteger", vrs, Integer)
            is_out = [self.interface[self.vars[vr].name].causality == "output" for vr in vrs]
            plan = self._store("geti", vrs, (_merged_getter([self.vars[vr].name for vr in vrs],
                                                            is_out), any(is_out)))
        get, outputs = plan
        if outputs:
            self._ensure_current()                # as the outputs' getters (_get_output) do
        try:
            vals = get(self._outputs, self.values)
        except KeyError:                          # not (yet) among the outputs
            vals = (None,)
        if None not in vals:
            return list(map(int, vals))
        return super().get_integer(vrs)

    def set_integer(self, vrs, values):
        self._check_refs("setInteger", vrs, Integer)
        super().set_integer(vrs, values)

    def get_boolean(self, vrs):
        self._check_refs("getBoolean", vrs, Boolean)
        return super().get_boolean(vrs)

    def set_boolean(self, vrs, values):
        self._check_refs("setBoolean", vrs, Boolean)
        super().set_boolean(vrs, values)

    def get_string(self, vrs):
        self._check_refs("getString", vrs, String)
        return super().get_string(vrs)

    def set_string(self, vrs, values):
        self._check_refs("setString", vrs, String)
        super().set_string(vrs, values)

    # -- values -------------------------------------------------------------------------------
    def _set(self, name: str, value) -> None:
        var = self.interface[name]
        if var.causality == "parameter" and var.variability == "fixed" and self.phase in (
                "stepping", "terminated"):
            msg = (f"{name} is a fixed parameter and cannot be changed after initialisation "
                   f"(tried to set {value!r}); the value stays {self.values[name]!r}")
            self.log(_escape(msg), Fmi2Status.error)
            raise FmiError(msg)
        self.values[name] = value
        if var.causality == "parameter":
            self._dirty = True

    def _ensure_current(self) -> None:
        """In initialisation mode, outputs (InitialUnknowns) follow the parameters set so far."""
        if self.phase == "initialization" and self._dirty:
            self._initialise()
            self._dirty = False

    def _get_output(self, name: str):
        self._ensure_current()
        return self._outputs.get(name, 0)

    def _fail(self, msg: str) -> None:
        """Log an error and raise :class:`FmiError` (the call returns fmi2Error)."""
        self.log(_escape(msg), Fmi2Status.error)
        raise FmiError(msg)

    def _check_finite_params(self) -> None:
        bad = [f"{n} = {v!r}" for n, v in self.values.items()
               if self.interface[n].causality == "parameter" and self.interface[n].type == "Real"
               and not math.isfinite(float(v))]
        if bad:
            self._fail("non-finite parameter value(s): " + ", ".join(bad))

    def _check_step(self, current_time: float, step_size: float, max_step: float) -> bool:
        """Validate a doStep call; log and return False (Discard) if it cannot be taken."""
        if self.phase != "stepping":
            self.log(_escape(f"doStep called in phase '{self.phase}'; call "
                             "fmi2ExitInitializationMode first"), Fmi2Status.error)
            return False
        if not (math.isfinite(step_size) and 0.0 < step_size <= max_step):
            self.log(_escape(f"communication step {step_size!r} s at t = {current_time!r} s "
                             f"rejected: it must be finite and in (0, {max_step:g}] s"),
                     Fmi2Status.discard)
            return False
        if not math.isfinite(current_time):
            self.log(_escape(f"non-finite communication point {current_time!r}"), Fmi2Status.discard)
            return False
        return True

    # -- lifecycle ------------------------------------------------------------------------------
    def enter_initialization_mode(self):
        if self.phase != "instantiated":
            self._fail(f"fmi2EnterInitializationMode called in phase '{self.phase}'; it is only "
                       "allowed once, after fmi2Instantiate or fmi2Reset (state unchanged)")
        self.phase = "initialization"

    def exit_initialization_mode(self):
        if self.phase != "initialization":
            self._fail(f"fmi2ExitInitializationMode called in phase '{self.phase}'; call "
                       "fmi2EnterInitializationMode first (state unchanged)")
        self._check_finite_params()
        self._initialise()        # may raise with a logged message
        self._dirty = False
        self.phase = "stepping"

    def terminate(self):
        self.phase = "terminated"

    def _initialise(self) -> None:
        raise NotImplementedError

    # -- model description --------------------------------------------------------------------
    def to_xml(self, model_options: Dict[str, str] = dict()) -> Element:
        root = super().to_xml(model_options)
        # UnitDefinitions go right after the CoSimulation element (FMI 2.0 schema order)
        units = Element("UnitDefinitions")
        used = sorted({v.unit for v in self.interface.values() if v.unit})
        for u in used:
            unit = SubElement(units, "Unit", name=u)
            exps = UNITS[u]
            if exps:
                SubElement(unit, "BaseUnit", {k: str(e) for k, e in exps.items()})
        cs_pos = list(root).index(root.find("CoSimulation"))
        root.insert(cs_pos + 1, units)
        sv_by_name = {sv.get("name"): sv for sv in root.find("ModelVariables")}
        for name, var in self.interface.items():
            if var.unit and var.type == "Real":
                sv_by_name[name].find("Real").set("unit", var.unit)
        # InitialUnknowns: every output (initial = calculated by default)
        structure = root.find("ModelStructure")
        init = SubElement(structure, "InitialUnknowns")
        for i, sv in enumerate(root.find("ModelVariables")):
            if sv.get("causality") == "output":
                SubElement(init, "Unknown", index=str(i + 1))
        return root

    # -- FMU state ------------------------------------------------------------------------------
    def _get_fmu_state(self):
        return copy.deepcopy({"values": self.values, "outputs": self._outputs, "phase": self.phase,
                              "core": self._core_state()})

    def _set_fmu_state(self, state) -> None:
        state = copy.deepcopy(state)
        rebuild = state["core"] is not None and any(
            self.values.get(n) != v for n, v in state["values"].items()
            if self.interface[n].causality == "parameter")
        self.values = state["values"]
        if rebuild:
            # the state was taken with other parameters (e.g. deserialised into an instance
            # initialised differently): rebuild the core from them before restoring its state
            self._initialise()
        self._outputs = state["outputs"]
        self.phase = state["phase"]
        self._restore_core_state(state["core"])

    @staticmethod
    def _fmu_state_to_bytes(state) -> bytes:
        return pickle.dumps(state, protocol=4)

    @staticmethod
    def _fmu_state_from_bytes(data: bytes):
        return pickle.loads(data)

    def _core_state(self):
        raise NotImplementedError

    def _restore_core_state(self, core) -> None:
        raise NotImplementedError
