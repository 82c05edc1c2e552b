"""Recording a co-simulation: one row per communication point of chosen variables of every
component (:class:`Recorder`), and the CSV files of a run (:func:`write_csv`, :func:`read_csv`,
:func:`check_writable`)."""
from __future__ import annotations

import csv
import os
from pathlib import Path
from typing import Dict, List, Mapping, Sequence

import numpy as np

from .errors import Calls
from .instance import ArrayIO

_TYPES = ("Real", "Integer", "Boolean")          # String variables are not recorded


#: causalities whose values cannot change after initialisation unless the master sets them
#: (this recorder's masters never set a parameter while stepping)
_CONSTANT_CAUSALITIES = ("parameter", "calculatedParameter")


class Recorder:
    """Rows ``[t, values...]`` of the variables ``names[component]`` of every instance.

    Columns are ``time`` and ``<component>.<variable>``, per component in the order Real,
    Integer, Boolean (within each type, the variables in ``names`` order); :meth:`data` returns
    Integer and Boolean columns with their own dtype. Parameters (and constants) are read at
    the first recorded row only and repeated in every row: after initialisation they change only
    when the master sets them, which the co-simulation masters here never do while stepping.
    """

    def __init__(self, instances: Mapping[str, object], names: Mapping[str, Sequence[str]],
                 n_rows: int, calls: Calls = None):
        self.instances = instances
        self.calls = calls or Calls()
        self.groups: Dict[str, Dict[str, tuple]] = {}
        self.columns: List[str] = ["time"]
        #: per (component, type) with variables: (component, ArrayIO, column index array,
        #: the FMI function's name), the varying ones and those read once
        self._reads: List[tuple] = []
        self._once: List[tuple] = []
        self._first = None                       # the row the constant columns were read into
        for comp, vnames in names.items():
            g = {typ: ([], []) for typ in _TYPES}
            const = {typ: [] for typ in _TYPES}
            for n in vnames:
                v = instances[comp].var(n)
                typ = "Integer" if v.type == "Enumeration" else v.type
                if typ in g:
                    g[typ][0].append(n)
                    g[typ][1].append(v.valueReference)
                    const[typ].append(v.causality in _CONSTANT_CAUSALITIES
                                      or v.variability == "constant")
            self.groups[comp] = g
            for typ in _TYPES:
                j = len(self.columns)
                for once, target in ((False, self._reads), (True, self._once)):
                    pick = [i for i, c in enumerate(const[typ]) if c == once]
                    if pick:
                        io = ArrayIO(instances[comp].fmu, typ, [g[typ][1][i] for i in pick])
                        cols = np.array([j + i for i in pick], dtype=np.intp)
                        target.append((comp, io, _as_slice(cols), f"fmi2Get{typ}"))
                self.columns += [f"{comp}.{v}" for v in g[typ][0]]
        self.buf = np.empty((n_rows, len(self.columns)))

    def record(self, k: int, t: float) -> None:
        """Row ``k``: the time ``t`` and the current values (parameters: see the class)."""
        row = self.buf[k]
        row[0] = t
        if self._first is None:
            for comp, io, cols, call in self._once:
                self.calls(comp, call)
                row[cols] = io.get()
            self._first = k
        for comp, io, cols, call in self._reads:
            self.calls(comp, call)
            row[cols] = io.get()

    def data(self) -> Dict[str, np.ndarray]:
        """Column name -> (N,) array (the rows recorded so far and beyond, as written)."""
        if self._first is not None:
            first = self.buf[self._first]
            for _, _, cols, _ in self._once:
                self.buf[:, cols] = first[cols]
        data = {c: self.buf[:, j].copy() for j, c in enumerate(self.columns)}
        for comp, g in self.groups.items():
            for v in g["Integer"][0]:
                data[f"{comp}.{v}"] = data[f"{comp}.{v}"].astype(np.int64)
            for v in g["Boolean"][0]:
                data[f"{comp}.{v}"] = data[f"{comp}.{v}"].astype(bool)
        return data


def _as_slice(cols: np.ndarray):
    """``cols`` (k,) increasing column indices as a slice where they are consecutive (a basic
    index: assignment without a fancy-index copy), else the array."""
    if len(cols) and cols[-1] - cols[0] + 1 == len(cols):
        return slice(int(cols[0]), int(cols[-1]) + 1)
    return cols


def check_writable(path: str | Path) -> Path:
    """Check, before a long run, that a results file can be written at ``path`` (its folder is
    created); raises OSError naming the path otherwise."""
    path = Path(path)
    if path.is_dir():
        raise IsADirectoryError(f"{path} is a directory; give a file name for the results")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise OSError(f"cannot create the folder of {path}: {e.strerror or e}") from None
    if not path.parent.is_dir():
        raise NotADirectoryError(f"{path.parent} is not a folder; cannot write {path}")
    if (path.exists() and not os.access(path, os.W_OK)) or not os.access(path.parent, os.W_OK):
        raise PermissionError(f"cannot write {path}: permission denied")
    return path


def write_csv(path: str | Path, data: Mapping[str, np.ndarray]) -> Path:
    """Write columns ``data`` (name -> 1-D array) to ``path``; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(data)
    cols = [np.asarray(data[n]) for n in names]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        for i in range(len(cols[0]) if cols else 0):
            w.writerow([repr(float(c[i])) if c.dtype.kind == "f" else str(c[i]) for c in cols])
    return path


def read_csv(path: str | Path) -> Dict[str, np.ndarray]:
    """Read a CSV written by :func:`write_csv` (or any numeric CSV with a header row);
    non-numeric columns are returned as string arrays."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        raise ValueError(f"{path}: empty CSV file")
    header = rows[0]
    for k, r in enumerate(rows[1:]):
        if r and len(r) != len(header):
            raise ValueError(f"{path}: line {k + 2} has {len(r)} fields, the header "
                             f"{len(header)}; not a result CSV")
    body = [r for r in rows[1:] if r]
    out = {}
    for j, n in enumerate(header):
        col = [r[j] for r in body]
        try:
            out[n] = np.array([float(x) for x in col])
        except ValueError:
            out[n] = np.array(col)
    return out
