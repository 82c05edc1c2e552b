"""Start values of a run: the SSD's ParameterBindings, a named parameter set instead of the
bound ``.ssv``, and explicit overrides, applied between fmi2Instantiate and initialisation as
SSP 1.0 prescribes; and :func:`parse_assignments`, the one parser of ``NAME=VALUE`` overrides
(``--set`` of ``spacerobot run`` and ``spacerobot sweep``)."""
from __future__ import annotations

import collections
from pathlib import Path
from typing import Dict, List, Mapping, Optional, Sequence, Tuple

from .errors import Calls, SimulationError
from .reader import ParameterValue, SystemInfo, read_ssv


def parse_assignments(items: Optional[Sequence[str]]) -> Dict[str, float]:
    """``["plant.base.v0[1]=5", ...]`` -> ``{"plant.base.v0[1]": 5.0}``; ValueError naming
    the item otherwise."""
    out = {}
    for item in items or ():
        name, sep, val = item.partition("=")
        if not sep or not name.strip():
            raise ValueError(f"--set expects NAME=VALUE, got {item!r}")
        try:
            out[name.strip()] = float(val)
        except ValueError:
            raise ValueError(f"--set {name.strip()}: {val.strip()!r} is not a number") from None
    return out


def resolve_parameter_set(info: SystemInfo, root_dir: Path,
                          parameter_set: str) -> Tuple[str, Path]:
    """``(name, path)`` of a parameter set given by name (``resources/<name>.ssv``) or path."""
    p = Path(parameter_set)
    if p.suffix == ".ssv" and p.exists():
        return p.stem, p
    path = root_dir / "resources" / f"{parameter_set}.ssv"
    if not path.exists():
        raise ValueError(f"unknown parameter set {parameter_set!r}; this system has "
                         f"{info.parameter_sets or 'none'} (or give the path of an .ssv file)")
    return parameter_set, path


def chosen_values(info: SystemInfo, root_dir: Path,
                  parameter_set: Optional[str]) -> Tuple[Optional[str], Dict[str, List]]:
    """``(set name, {component: values})``: the values of ``parameter_set`` for every component
    the SSD binds an ``.ssv`` to (``(None, {})`` without a parameter set).

    A component bound to a file in ``resources/`` gets the set's ``resources/<name>.ssv``; one
    bound to a file in a folder of its own, ``resources/<folder>/`` (the estimator's settings
    of a set, :data:`.ssd.ESTIMATOR_SET_DIR`), gets ``<folder>/<name>.ssv`` beside the set's
    file, or no values if the set has none there (the FMU's defaults)."""
    if parameter_set is None:
        return None, {}
    name, path = resolve_parameter_set(info, root_dir, parameter_set)
    values = read_ssv(path)
    out = {}
    for c in info.components.values():
        bound = [b.source for b in c.bindings if b.source and b.source.endswith(".ssv")]
        if not bound:
            continue
        folder = Path(bound[0]).parent
        if folder.name == "resources" or folder == Path("."):
            out[c.name] = values
        else:
            own = path.parent / folder.name / path.name
            out[c.name] = read_ssv(own) if own.exists() else []
    if not out:
        raise SimulationError("the SSD binds no .ssv file to a component, so a named "
                              "parameter set has nothing to replace")
    return name, out


def split_overrides(overrides: Optional[Mapping[str, object]],
                    components: Sequence[str]) -> Dict[str, List[Tuple[str, object]]]:
    """``{'<component>.<variable>': value}`` -> ``{component: [(variable, value)]}``; KeyError
    for an unknown component."""
    by_comp: Dict[str, List[Tuple[str, object]]] = collections.defaultdict(list)
    for key, value in (overrides or {}).items():
        comp, _, var = key.partition(".")
        if comp not in components or not var:
            raise KeyError(f"override {key!r}: expected '<component>.<variable>' with "
                           f"component one of {sorted(components)}")
        by_comp[comp].append((var, value))
    return dict(by_comp)


def apply_value(inst, name: str, typ: str, value, unit: Optional[str], where: str) -> bool:
    """Set one parameter value from a binding; returns False if the FMU has no such variable
    (SSP 1.0: such parameters are ignored)."""
    v = inst.vars.get(name)
    if v is None:
        return False
    if unit and v.type == "Real":
        fmu_unit = getattr(v, "unit", None) or (v.declaredType.unit if getattr(
            v, "declaredType", None) is not None else None)
        if fmu_unit and fmu_unit != unit:
            raise SimulationError(f"{where}: parameter {inst.name}.{name} has unit {unit!r} but "
                                  f"the FMU variable has unit {fmu_unit!r} (no unit conversion)")
    inst.set(name, value)
    return True


def apply_component_bindings(inst, comp, chosen: Mapping[str, List[ParameterValue]],
                             calls: Calls) -> None:
    """The component's ParameterBindings in element order; a bound ``.ssv`` is replaced by
    ``chosen[component]`` if given."""
    calls(comp.name, "setting parameters")
    for b in comp.bindings:
        vals = chosen[comp.name] if (comp.name in chosen and b.source
                                     and b.source.endswith(".ssv")) else b.values
        for pname, typ, val, unit in vals:
            apply_value(inst, b.prefix + pname, typ, val, unit, f"binding {b.source or 'inline'}")


def apply_system_bindings(instances: Mapping[str, object], info: SystemInfo,
                          calls: Calls) -> None:
    """The root System's bindings (``<component>.<variable>`` names), which take precedence
    over the component level."""
    for b in info.system_bindings:
        for pname, typ, val, unit in b.values:
            comp, _, var = (b.prefix + pname).partition(".")
            if comp in instances:
                calls(comp, "setting parameters")
                apply_value(instances[comp], var, typ, val, unit,
                            f"system binding {b.source or 'inline'}")


def apply_overrides(instances: Mapping[str, object],
                    by_comp: Mapping[str, List[Tuple[str, object]]], calls: Calls) -> None:
    """Explicit overrides, last; KeyError with suggestions for an unknown variable."""
    for comp, items in by_comp.items():
        for var, value in items:
            instances[comp].var(var)
            calls(comp, f"setting override {var}")
            instances[comp].set(var, value)
