"""Workarounds for pythonfmu 0.7.0 on the Python side of the FMUs; delete them with the bugs.

- :func:`survive_fatal` (:func:`guard_entry_points`): pythonfmu's C++ layer releases one
  reference too many on every exception; the wrapper balances it.
- :func:`binary_hooks` / :class:`BinaryHooks`: pythonfmu maps every exception to ``fmi2Fatal``.
  The project's front library (``front_library.c``, the FMU's binary) returns ``fmi2Error``
  instead when the Python side flags the exception as a refusal that left the state unchanged.
  With pythonfmu's stock binary (an FMU built where no C compiler was found) there is no such
  flag, and the exit double free is avoided from Python instead (:meth:`BinaryHooks.guard_exit`).
"""
from __future__ import annotations

import ctypes
import functools
import os
import sys
from typing import Callable, Dict, Optional, Tuple, Type

#: methods the pythonfmu C++ layer calls on the slave instance
ENTRY_POINTS = ("setup_experiment", "enter_initialization_mode", "exit_initialization_mode",
                "do_step", "terminate", "set_real", "set_integer", "set_boolean", "set_string",
                "get_real", "get_integer", "get_boolean", "get_string", "_get_fmu_state",
                "_set_fmu_state")

_Py_IncRef = ctypes.pythonapi.Py_IncRef
_Py_IncRef.argtypes = [ctypes.py_object]
_Py_IncRef.restype = None


class BinaryHooks:
    """What the FMU's binary (``binaries/linux64/<model identifier>.so``) offers the Python side.

    ``flag_error`` is the front library's ``spacerobot_flag_error`` (None with pythonfmu's stock
    binary, or off Linux): called right before an exception leaves an entry point, it makes that
    call return ``fmi2Error`` instead of ``fmi2Fatal``.
    """

    def __init__(self, so_path: str):
        self.so_path = so_path
        self.lib: Optional[ctypes.CDLL] = None
        self.flag_error: Optional[Callable[[], None]] = None
        try:       # the binary the host loaded; RTLD_NOLOAD: never load a second copy
            self.lib = ctypes.CDLL(so_path, mode=getattr(os, "RTLD_NOLOAD", 4) | os.RTLD_NOW)
        except OSError:
            return
        try:
            fn = self.lib.spacerobot_flag_error
        except AttributeError:
            return                                  # pythonfmu's stock binary
        fn.restype, fn.argtypes = None, []
        self.flag_error = fn

    def guard_exit(self) -> None:
        """Stock binary in a Python host: release pythonfmu's interpreter guard at Python exit.

        pythonfmu 0.7.0 keeps the guard in a static ``std::shared_ptr`` and also resets it from an
        ``__attribute__((destructor))`` (``finalizePythonInterpreter``). At ``exit()`` the C++
        static destructor runs first, then the destructor function frees the control block a
        second time (valgrind: invalid read in finalizePythonInterpreter); glibc then sometimes
        aborts ("corrupted double-linked list") after the host's work is done. Calling the
        exported function from Python's ``atexit``, which runs before the C exit handlers,
        releases the guard once while it is alive. Only when the host is a Python process
        (``sys.orig_argv`` non-empty): when pythonfmu started the interpreter itself, Python's
        atexit runs inside that very destructor. The front library does this itself, for
        every host, so nothing is done when it is the binary.
        """
        if (self.flag_error is not None or self.lib is None
                or not getattr(sys, "orig_argv", None) or self.so_path in _EXIT_GUARDED):
            return
        try:
            fn = self.lib.finalizePythonInterpreter
        except AttributeError:
            return                                  # another pythonfmu version
        import atexit

        fn.restype, fn.argtypes = None, []
        atexit.register(fn)
        _EXIT_GUARDED.add(self.so_path)


_EXIT_GUARDED: set = set()
_HOOKS: Dict[str, BinaryHooks] = {}


def binary_hooks(resources: str, model_identifier: str) -> BinaryHooks:
    """The :class:`BinaryHooks` of the FMU whose resources folder is ``resources`` (one per
    binary and process)."""
    so = os.path.normpath(os.path.join(resources or ".", os.pardir, "binaries", "linux64",
                                       model_identifier + ".so"))
    if so not in _HOOKS:
        _HOOKS[so] = BinaryHooks(so)
    return _HOOKS[so]


def survive_fatal(slave, method, hooks: BinaryHooks,
                  refusals: Tuple[Type[BaseException], ...] = ()):
    """Wrap an entry point so that an exception leaves the instance usable, and a refusal
    (an exception of a ``refusals`` class) is reported as ``fmi2Error`` where the binary can.

    pythonfmu 0.7.0's C++ ``handle_py_exception`` calls ``cleanPyObject()``, which Py_DECREFs
    the slave class, the slave instance and its log queue once per exception although it does
    not give up its references to them: after one exception the instance is garbage the next
    ``gc`` pass may free, and a second one (or one + fmi2FreeInstance a few times in one
    process) crashes the host. Taking one extra reference of each before the exception leaves
    C++ balances that decrement exactly.
    """
    @functools.wraps(method)
    def guarded(*args, **kwargs):
        try:
            return method(*args, **kwargs)
        except BaseException as e:
            for obj in (type(slave), slave, slave.log_queue):
                _Py_IncRef(obj)
            if isinstance(e, refusals) and hooks.flag_error is not None:
                hooks.flag_error()
            raise
    return guarded


def guard_entry_points(slave, hooks: BinaryHooks,
                       refusals: Tuple[Type[BaseException], ...] = ()) -> None:
    """Wrap every :data:`ENTRY_POINTS` method of ``slave`` with :func:`survive_fatal`."""
    for name in ENTRY_POINTS:
        setattr(slave, name, survive_fatal(slave, getattr(slave, name), hooks, refusals))
