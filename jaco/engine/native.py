"""The native walks: the C++ kernels (``jaco/engine/walk.cc`` and one file beside each module a
kernel serves), called through ``jax.ffi``.

The kernel is compiled when jaco is installed (``setup.py``; the XLA FFI headers come from
jaxlib). Where that failed (no C++ compiler), jaco runs the JAX walk, which defines the walk
anyway: the kernel takes the same moves bit for bit.

Which walk runs: ``JACO_WALK`` in the environment (``auto``, ``native`` or ``jax``), or
:func:`set_walk`; ``auto`` (the default) takes the native walk when it was built. The choice
applies to programs compiled after it (it is part of every compiled program's cache key).

This module is the one that loads the kernel library, registers its FFI targets and chooses
between a kernel and its JAX form (:func:`dispatch`); :func:`isas` and :func:`set_isa` name and
choose the instruction set of the lane kernels (``JACO_NATIVE_ISA``; docs/native.md). The wrappers of the engine's kernels (the
walk, the deposit, the shortcut) are here; a planner's own kernel's wrapper lives beside the
planner and calls it through :func:`ffi_call` (IACA's backtracking walk in
:mod:`jaco.planners.iaca`, the APF's next-cell table in :mod:`jaco.potential`).
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import threading
import warnings
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np

from ..errors import JacoError

CHOICES = ("auto", "native", "jax")
_TARGETS = {
    "jaco_walk": "JacoWalk",
    "jaco_backtrack": "JacoBacktrack",
    "jaco_deposit": "JacoDeposit",
    "jaco_uniforms": "JacoUniforms",
    "jaco_power": "JacoPower",
    "jaco_apf_next": "JacoApfNext",
    "jaco_shortcut": "JacoShortcut",
    "jaco_stopped": "JacoStopped",
    "jaco_move_weights": "JacoMoveWeights",
    "jaco_log_exp": "JacoLogExp",
}
_state: dict = {}


def _load():
    """Load the kernel library once: ``(library, None)`` or ``(None, reason)``."""
    if "lib" not in _state:
        lib, why = None, None
        try:
            spec = importlib.util.find_spec("jaco.engine._walk")
            if spec is None or not spec.origin:
                why = "the native walk was not built at install time (no C++ compiler?)"
            else:
                lib = ctypes.CDLL(spec.origin)
                _state["isa_error"] = _bind_isa(lib)  # before registering: a stale build lacks these
                for name, symbol in _TARGETS.items():
                    jax.ffi.register_ffi_target(name, jax.ffi.pycapsule(getattr(lib, symbol)), platform="cpu")
        except (OSError, AttributeError) as e:  # a stale or broken build
            lib, why = None, f"the native walk could not be loaded ({e})"
            _state["isa_error"] = None
        _state["lib"], _state["why"] = lib, why
    if _state.get("isa_error"):  # a JACO_NATIVE_ISA this kernel cannot honour: every use says so
        raise _state["isa_error"]
    return _state["lib"], _state["why"]


def _bind_isa(lib) -> JacoError | None:
    """Declare the kernel's instruction-set functions and apply ``JACO_NATIVE_ISA`` if set (the
    error, if it names a set this kernel cannot run)."""
    lib.jaco_isa_name.restype = ctypes.c_char_p
    for name in ("jaco_isa_count", "jaco_isa_built", "jaco_isa_runs", "jaco_isa_get", "jaco_isa_set", "jaco_tabu_get"):
        getattr(lib, name).restype = ctypes.c_int
    lib.jaco_tabu_set.restype, lib.jaco_tabu_set.argtypes = ctypes.c_int, [ctypes.c_int]
    lib.jaco_stop_set.restype, lib.jaco_stop_set.argtypes = None, [ctypes.c_int]
    lib.jaco_iterations_done.restype, lib.jaco_iterations_done.argtypes = ctypes.c_int, [ctypes.c_int]
    choice = os.environ.get("JACO_NATIVE_ISA")
    try:
        if choice:
            _set_isa(lib, choice, "JACO_NATIVE_ISA")
    except JacoError as e:
        return e
    return None


def isas() -> dict[str, str]:
    """The instruction sets of the lane kernels: ``{name: state}``, the state ``"active"``,
    ``"runs"`` (built, and this CPU has it), ``"not on this CPU"`` or ``"not built"``; widest last.
    Empty when the kernel is not available."""
    lib = _load()[0]
    if lib is None:
        return {}
    active = lib.jaco_isa_get()
    out = {}
    for i in range(lib.jaco_isa_count()):
        state = "not built" if not lib.jaco_isa_built(i) else "runs" if lib.jaco_isa_runs(i) else "not on this CPU"
        out[lib.jaco_isa_name(i).decode()] = "active" if i == active else state
    return out


def isa() -> str | None:
    """The instruction set the lane kernels use now (None without the kernel)."""
    return next((name for name, state in isas().items() if state == "active"), None)


def set_isa(choice: str | None) -> None:
    """Use the lane kernels built for instruction set ``choice`` (``"baseline"``, ``"avx2"``,
    ``"avx512"``; see :func:`isas`), or with ``None`` the widest one this CPU runs (the default).
    Every set takes the same moves bit for bit: this changes speed only, for calls from now on,
    compiled or not. A set that was not built, or that this CPU lacks, is an error."""
    try:
        _load()
    except JacoError:  # JACO_NATIVE_ISA named a set it cannot run: this choice replaces it
        pass
    lib = _state["lib"]
    if lib is None:
        raise JacoError(f"no native kernel to choose an instruction set for: {_state['why']}")
    _set_isa(lib, choice or "auto", "set_isa")
    _state["isa_error"] = None


def _set_isa(lib, choice: str, where: str) -> None:
    names = [lib.jaco_isa_name(i).decode() for i in range(lib.jaco_isa_count())]
    if choice == "auto":
        lib.jaco_isa_set(-1)
        return
    if choice not in names:
        raise JacoError(f"{where}: unknown instruction set {choice!r}; the kernel knows {', '.join(names)} (or auto)")
    if lib.jaco_isa_set(names.index(choice)) != 0:
        state = "was not built" if not lib.jaco_isa_built(names.index(choice)) else "is not supported by this CPU"
        runs = ", ".join(n for i, n in enumerate(names) if lib.jaco_isa_runs(i))
        raise JacoError(f"{where}: instruction set {choice!r} {state}; this kernel runs {runs} (or auto)")


#: The dying-ant lane walk's ways of keeping its tabu lists (:func:`set_tabu`), by the kernel's codes.
TABU_LAYOUTS = ("lanes", "planes")


def set_tabu(choice: str | None) -> None:
    """How the dying-ant lane walk keeps its ants' tabu lists: ``"lanes"``, a bit for each lane,
    cleared along an ant's path when it stops; ``"planes"``, a bit for each ant, all cleared by
    one scan once the walk ends (wherever the planes fit in 16 MiB a thread); or with ``None`` the
    kernel's choice (the default: planes where a colony's take at most 16 KiB, lanes beyond).
    Every layout takes the same moves bit for bit; this changes speed only, for calls from now on
    (for tests and measurements; docs/native.md, "Tabu lists as bits")."""
    lib = _load()[0]
    if lib is None:
        raise JacoError(f"no native kernel to choose a tabu layout for: {_state['why']}")
    if choice is not None and choice not in TABU_LAYOUTS:
        raise JacoError(
            f"set_tabu: unknown tabu layout {choice!r}; the kernel knows {', '.join(TABU_LAYOUTS)} (or None)"
        )
    lib.jaco_tabu_set(-1 if choice is None else TABU_LAYOUTS.index(choice))


def tabu() -> str | None:
    """The tabu layout :func:`set_tabu` chose (None: the kernel's choice, or no kernel)."""
    lib = _load()[0]
    code = -1 if lib is None else lib.jaco_tabu_get()
    return None if code < 0 else TABU_LAYOUTS[code]


def available() -> bool:
    """Whether the native kernel was built and loads."""
    return _load()[0] is not None


def unavailable_reason() -> str | None:
    return _load()[1]


def _check(choice, where: str = "walk") -> str:
    if choice not in CHOICES:
        raise JacoError(f"{where} must be one of {', '.join(CHOICES)}, got {choice!r}")
    if choice == "native" and not available():
        raise JacoError(f"walk 'native' was asked for, but {unavailable_reason()}")
    return choice


def set_walk(choice: str | None) -> None:
    """Choose the walk of programs compiled from now on: ``"auto"``, ``"native"`` or ``"jax"``
    (``None``: back to ``JACO_WALK`` or ``auto``)."""
    if choice is None:
        _state.pop("choice", None)
    else:
        _state["choice"] = _check(choice)


def active_walk() -> str:
    """``"native"`` or ``"jax"``: the walk that CPU programs compiled now use."""
    choice = _state.get("choice") or _check(os.environ.get("JACO_WALK") or "auto", "JACO_WALK")
    if choice == "auto":
        return "native" if available() else "jax"
    return choice


def ffi_call(target: str, result_shapes: Any, vmap_method: str = "broadcast_all", **kwargs: Any) -> Callable[..., Any]:
    """``jax.ffi.ffi_call`` of one of the kernels (``target``, a name of :data:`_TARGETS`),
    the library loaded and its targets registered first; the kernel wrappers beside the code they
    serve (:func:`jaco.planners.iaca.native_backtrack_walk`, :func:`jaco.potential.native_apf_next`,
    :func:`jaco.engine.weights.native_move_weights`) call their kernels through it."""
    _load()
    return jax.ffi.ffi_call(target, result_shapes, vmap_method=vmap_method, **kwargs)


def dispatch(native_fn: Callable[..., Any], jax_fn: Callable[..., Any], *args: Any) -> Any:
    """``native_fn(*args)`` where the program runs on CPU with the native walk active, else
    ``jax_fn(*args)``: the one switch between a kernel and the JAX code that it equals."""
    if active_walk() == "native":
        return jax.lax.platform_dependent(*args, cpu=native_fn, default=jax_fn)
    return jax_fn(*args)


#: Without the kernel's flag, a run asks the host whether to stop every this many iterations (a
#: host callback costs tens of microseconds; reading the kernel's flag, well under one).
STOP_STRIDE = 8


_STOP = threading.Event()  # the host's copy of the flag: read by the JAX walk's runs and by progress reports


def set_stop(on: bool) -> None:
    """Ask every compiled run's iteration loop to end (``True``: the user interrupted the call)
    or let them run (``False``). :func:`jaco.progress.run_interruptibly` sets and clears it."""
    (_STOP.set if on else _STOP.clear)()
    if _state.get("lib") is not None:
        _state["lib"].jaco_stop_set(int(on))


def stop_is_set() -> bool:
    """Whether :func:`set_stop` asked the runs to end."""
    return _STOP.is_set()


def iterations_done(reset: bool = False) -> int:
    """The most iterations a compiled run on the kernel has finished since the last reset (each
    iteration loop hands its count to the kernel's stop flag, :func:`stop_requested`); 0 without
    the kernel or when only JAX-walk runs ran. ``reset``: set it back to 0 (after reading it).
    :mod:`jaco.progress` reads it to move a bar without a host callback."""
    lib = _state.get("lib")
    return 0 if lib is None else int(lib.jaco_iterations_done(int(reset)))


def stop_requested(t: jax.Array) -> jax.Array:
    """Traced: whether the loop at iteration ``t`` should end because the call was interrupted
    (:func:`set_stop`): the kernel's flag, every iteration, on CPU with the native walk; else the
    host's every :data:`STOP_STRIDE` iterations. It reads
    no result of the run, so it changes none."""
    return dispatch(_kernel_stopped, _host_stopped, jnp.asarray(t, jnp.int32))


def _kernel_stopped(t: jax.Array) -> jax.Array:
    # The iteration as operand keeps the call in the loop and apart from other iterations' calls;
    # the kernel also keeps it as the run's progress (iterations_done).
    # (Not marked has_side_effect: that orders XLA's work around it and cost 20 µs an iteration.)
    return jax.ffi.ffi_call("jaco_stopped", jax.ShapeDtypeStruct((), jnp.bool_))(t)


def _host_can_call_back() -> bool:
    """Whether jax has its CPU backend, which host callbacks need (``JAX_PLATFORMS=cuda`` alone
    leaves it out); without it a run cannot ask the host and is interrupted between calls only."""
    if "host_callbacks" not in _state:
        try:
            jax.devices("cpu")
            _state["host_callbacks"] = True
        except RuntimeError:
            _state["host_callbacks"] = False
            warnings.warn(
                "jax has no CPU backend (JAX_PLATFORMS lists no 'cpu'): an interrupted run stops at the end "
                "of its compiled call, not at its next iteration; add cpu to JAX_PLATFORMS (e.g. 'cuda,cpu')",
                stacklevel=3,
            )
    return _state["host_callbacks"]


def _host_stopped(t: jax.Array) -> jax.Array:
    if not _host_can_call_back():
        return jnp.bool_(False)

    def asked():
        return np.bool_(_STOP.is_set())

    # A pure callback (an io_callback cannot sit in a vmapped cond): called with the iteration,
    # so it is asked again in every iteration that checks, never answered once for all.
    def ask():
        return jax.pure_callback(lambda _: asked(), jax.ShapeDtypeStruct((), jnp.bool_), t, vmap_method="broadcast_all")

    return jax.lax.cond(t % STOP_STRIDE == 0, ask, lambda: jnp.bool_(False))


def walk(
    weights: jax.Array,
    words: jax.Array,
    start: Any,
    goal: Any,
    q0: jax.Array | float,
    offsets: Any,
    previous: jax.Array | None = None,
    *,
    n_ants: int,
    steplimit: int,
    exploit: bool,
) -> Any:
    """The kernel's walk; same arguments and results as :func:`jaco.engine.walk.jax_walk`.

    The kernel writes each step's ``from·8 + move`` only; the cell it entered, ``from +
    offsets[move]``, is computed here, so a program that never reads the cells (a sweep without
    paths) neither fills nor writes an ``(S, A)`` buffer for them. It writes the steps over
    ``previous`` in place (XLA aliases the two) and clears only the rows the last walks used."""
    _load()
    n = weights.shape[-2]
    if previous is None:
        previous = no_steps(weights.shape[:-2], steplimit, n_ants, n)
    out = (
        jax.ShapeDtypeStruct((steplimit, n_ants), jnp.int32),
        jax.ShapeDtypeStruct((n_ants,), jnp.int32),
        jax.ShapeDtypeStruct((n_ants,), jnp.int32),
        jax.ShapeDtypeStruct((n_ants,), jnp.bool_),
        jax.ShapeDtypeStruct((n,), jnp.bool_),
    )
    call = jax.ffi.ffi_call("jaco_walk", out, vmap_method="broadcast_all", input_output_aliases={6: 0})
    edges, *rest = call(
        weights, words, start, goal, q0, offsets, previous, steplimit=np.int64(steplimit), exploit=bool(exploit)
    )
    return edges, entered_cells(edges, offsets, n), *rest


def no_steps(batch: tuple[int, ...], steplimit: int, n_ants: int, n_cells: int) -> jax.Array:
    """Step buffers ``batch + (steplimit, n_ants)`` of walks that took no step: every edge ``8N``."""
    return jnp.full((*batch, steplimit, n_ants), 8 * n_cells, jnp.int32)


def entered_cells(edges: jax.Array, offsets: Any, n_cells: int) -> jax.Array:
    """The cell each step ``from·8 + move`` entered, ``from + offsets[move]``; -1 where ``edges``
    is out of range (``8N``: no step)."""
    # offsets[move] as selects, not a gather: XLA fuses selects into whatever reads the cells (a
    # path is one column), where it made a gather its own pass over every step slot.
    move, offsets = edges & 7, jnp.asarray(offsets, jnp.int32)
    offset = offsets[0]
    for k in range(1, 8):
        offset = jnp.where(move == k, offsets[k], offset)
    return jnp.where(edges < 8 * n_cells, (edges >> 3) + offset, -1)


def deposit(tau: jax.Array, targets: jax.Array, amounts: jax.Array) -> jax.Array:
    """The kernel's scatter-add ``tau[targets] += amounts`` (out-of-range targets dropped), in
    XLA's order: same arguments and result as :func:`jaco.engine.pheromone.deposit`'s JAX form;
    ``targets (S, C)`` or ``(S,)``, each column a walk (the steps it took first, then targets out
    of range); ``amounts`` a scalar, one value per column, or one per target."""
    _load()
    targets = jnp.asarray(targets, jnp.int32)
    amounts = jnp.asarray(amounts, jnp.float32)
    flat = targets.reshape(targets.shape[0], -1)
    per = amounts.reshape(-1)
    call = jax.ffi.ffi_call(
        "jaco_deposit",
        jax.ShapeDtypeStruct(tau.shape, jnp.float32),
        vmap_method="broadcast_all",
    )
    return call(tau, flat, per)


def shortcut(
    cells: jax.Array,
    bits: jax.Array,
    start: Any,
    offsets: Any,
    diagonal: Any,
    move_of: Any,
    *,
    window: int,
    passes: int,
) -> jax.Array:
    """The kernel's octile shortcut; same arguments and result as
    :func:`jaco.engine.local_search.jax_shortcut` (``cells (S, C)``, each column a path)."""
    _load()
    call = jax.ffi.ffi_call("jaco_shortcut", jax.ShapeDtypeStruct(cells.shape, jnp.int32), vmap_method="broadcast_all")
    return call(cells, bits, start, offsets, diagonal, move_of, window=np.int64(window), passes=np.int64(passes))


def power(x: jax.Array, a: jax.Array | float) -> jax.Array:
    """The kernel's :func:`jaco.engine.bitexact.power` (for tests)."""
    from .bitexact import TABLES

    _load()
    x = jnp.asarray(x, jnp.float32)
    call = jax.ffi.ffi_call("jaco_power", jax.ShapeDtypeStruct(x.shape, jnp.float32))
    return call(x, jnp.broadcast_to(jnp.asarray(a, jnp.float32), x.shape), jnp.asarray(TABLES))


def uniforms(words: jax.Array, ants: jax.Array, steps: jax.Array) -> jax.Array:
    """The kernel's uniforms of ``(ant, step)`` pairs (for tests against
    :func:`jaco.engine.walk.step_uniforms`)."""
    _load()
    out = jax.ShapeDtypeStruct(jnp.shape(ants), jnp.float32)
    return jax.ffi.ffi_call("jaco_uniforms", out)(
        jnp.asarray(words, jnp.uint32), jnp.asarray(ants, jnp.uint32), jnp.asarray(steps, jnp.uint32)
    )
