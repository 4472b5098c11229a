"""The compiled core's loader: numba, its cache, the switch between compiled and reference.

The physics' hot loops are written once, each in the module that states its equations:

- the valve's exact ZOH over a run of equal sub-steps: ``models.lti`` (``zoh_run``, 004
  section 2.1: s_(k+1) = A_d s_k + B_d p_ss, the gauge pressure clamped to [0, p_max]);
- the McKibben backbone and its contact band: ``models.muscle`` (``backbone``, ``softplus``);
- the Maxwell-slip braid friction on s = x + c_t F_bb^+: ``models.friction``;
- the loading drive's backward-Euler sub-step law and its replay:
  ``models.loading_servo.substep``;
- the coupled sub-step solve g(F) = F_m(p_+, X(F)) - F = 0 by bracketed Newton, with its settle
  test: ``models.coupling`` (``solve_mckibben``).

Each module registers its functions here: ``helper`` for one a kernel calls (numba compiles it
into its callers, ``register_jitable``; the Python function stays what it is) and ``kernel``
for an entry point the models call, which runs compiled once loaded and interpreted until
then (the same function, bit-equal: ``test/models/test_jit.py``). Every function repeats
the reference's floating-point operations in the reference's order. ``PAM_BENCH_CORE=python``
(or ``use('python')``) runs the reference; 000's straight-fibre muscle always does.

The kernels load in a background thread the first time an exchange brings ``LOAD_AT`` sub-steps
or more (``wanted``): numba's import and its cache cost about half a second, which a short
run with few sub-steps per exchange (the demo, a servo scene) never wins back. The compiled
cache goes to ``NUMBA_CACHE_DIR`` when set, else to ``$XDG_CACHE_HOME/pam_bench/numba``
(``~/.cache``): a wheel or a colcon ``install/`` is read-only, and numba's default
(``__pycache__`` beside the module) is not writable there.

numba is imported through ``import_numba``, which leaves out two imports numba makes for
features no kernel uses (docs/long_runs.md, "numba's load without SciPy's BLAS and coverage"):

- numba's array functions (``numba.np.arraymath``) ask once whether SciPy's BLAS is there, to
  compile ``np.dot`` and ``np.vdot`` of 1-D float arrays with it; asking imports
  ``scipy.linalg``. ``import_numba`` imports that module with the answer no: both then compile
  as numba's own loop. Every other use of BLAS or LAPACK (``np.linalg``) still asks for itself.
- numba imports ``coverage``, when it is installed (colcon-core, a test requirement, needs
  it), to report the lines of compiled functions to a running coverage. Where none runs
  (``coverage`` not imported yet), ``import_numba`` imports numba without it.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
import pathlib
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from collections.abc import Sequence

    import numpy as np

    Array = np.ndarray
    Values = np.ndarray | Sequence[float]
    """Read: an array (compiled) or a sequence (the objects' interpreted calls)."""
    Slots = np.ndarray | list[Any]
    """Written in place: an array or a list."""
else:
    Array = Values = Slots = Any

__all__ = ['available', 'enabled', 'core', 'wanted', 'LOAD_AT', 'use', 'start_loading',
           'cache_dir', 'helper', 'kernel', 'warm_up', 'Array', 'Values', 'Slots',
           'KERNEL_MODULES', 'compile_function', 'sources_key', 'import_numba']

F = TypeVar('F', bound=Callable[..., Any])

KERNEL_MODULES = ('pam_bench.models.lti', 'pam_bench.models.muscle', 'pam_bench.models.friction',
                  'pam_bench.models.loading_servo.substep', 'pam_bench.models.coupling',
                  'pam_bench.models.valve')
"""The modules that hold the kernels and their helpers (imported before compiling; their
sources key numba's cache, ``sources_key``). The valve's: ``twin.bench_holds`` compiles its
pure functions into its own."""


def cache_dir() -> pathlib.Path:
    """Where numba keeps the compiled functions (module docstring)."""
    env = os.environ.get('NUMBA_CACHE_DIR')
    if env:
        return pathlib.Path(env)
    base = os.environ.get('XDG_CACHE_HOME') or str(pathlib.Path.home() / '.cache')
    return pathlib.Path(base) / 'pam_bench' / 'numba'


os.environ.setdefault('NUMBA_CACHE_DIR', str(cache_dir()))

_WANTED = os.environ.get('PAM_BENCH_CORE', 'compiled') != 'python'
_READY = threading.Event()           # the kernels are compiled (or loaded from the cache)
_FAILED: list[str] = []              # why they could not be
_LOCK = threading.Lock()
_LOADER: threading.Thread | None = None


def available() -> bool:
    """Whether the compiled kernels load here (waits for them)."""
    _load()
    return _READY.is_set()


def enabled() -> bool:
    """Whether the compiled core runs now: wanted and loaded. Until the kernels have loaded
    (``start_loading``: numba's import and its cache take about half a second) the reference
    runs; the two are bit-equal, so a run does not depend on when the switch happens."""
    return _WANTED and _READY.is_set()


def core() -> str:
    """The core asked for, loaded or not: 'compiled' (the default) or 'python' (``use``, or
    ``PAM_BENCH_CORE=python``). ``enabled`` says whether it runs yet: what a caller that
    switches the core for a while must restore is this, not ``enabled``, or a switch made
    before the kernels have loaded would leave the process on the reference for good."""
    return 'compiled' if _WANTED else 'python'


def use(core: str) -> None:
    """Run the 'compiled' core (waiting for it to load) or the 'python' reference from now on
    (tests compare them).

    Raises:
        ValueError: an unknown core, or 'compiled' where numba does not load.
    """
    global _WANTED
    if core not in ('compiled', 'python'):
        raise ValueError(f"core {core!r}: 'compiled' or 'python'")
    if core == 'compiled':
        _load()
        if not _READY.is_set():
            raise ValueError(f'the compiled core does not load: {_FAILED[0]}')
    _WANTED = core == 'compiled'


LOAD_AT = 32
"""Sub-steps in one call that make the compiled core worth loading (module docstring)."""
FEW = 4
"""Below this many sub-steps a call runs on the reference: packing the arrays costs more than
the few sub-steps (a 1 ms servo exchange has one)."""


def wanted(n: int) -> bool:
    """Whether to run a call of ``n`` sub-steps on the compiled core: yes once it is loaded;
    a call of ``LOAD_AT`` or more starts loading it."""
    if _READY.is_set():
        return _WANTED and n >= FEW
    if n >= LOAD_AT:
        start_loading()
    return False


def start_loading() -> None:
    """Load the kernels in a background thread (a run starts on the reference meanwhile)."""
    global _LOADER
    with _LOCK:
        if _LOADER is None and _WANTED:
            _LOADER = threading.Thread(target=_load, name='pam_bench-compiled-core',
                                       daemon=True)
            _LOADER.start()


_HELPERS: list[Callable[..., Any]] = []
"""Called by the kernels: registered with numba (``register_jitable``) when the core loads."""
_KERNELS: dict[str, Callable[..., Any]] = {}
"""The entry points by name: each compiled into ``_COMPILED`` when the core loads."""
_COMPILED: dict[str, Callable[..., Any]] = {}
_EXAMPLES: dict[str, Callable[[], tuple[Any, ...]]] = {}


def helper(fn: F) -> F:
    """Register ``fn`` as a function the kernels call; returns it unchanged."""
    _HELPERS.append(fn)
    return fn


def kernel(name: str, fn: Callable[..., Any],
           example: Callable[[], tuple[Any, ...]]) -> Callable[..., Any]:
    """Register ``fn`` as the kernel ``name``; returns the entry point the models call: the
    compiled function once loaded, ``fn`` itself until then.

    Args:
        name: the kernel's name (one per kernel).
        fn: the function, written in the subset numba compiles.
        example: builds arguments of the types a run passes; the load calls the compiled
            function once with them, which compiles it or loads it from the cache.
    """
    _KERNELS[name] = fn
    _EXAMPLES[name] = example
    compiled = _COMPILED

    def entry(*args: Any) -> Any:
        return compiled.get(name, fn)(*args)
    entry.__name__ = entry.__qualname__ = name
    entry.__doc__ = f'``{fn.__module__}.{fn.__name__}``, compiled once loaded.'
    return entry


def _load() -> None:
    """Compile every kernel (from numba's cache when it holds them); the Python functions
    stay what they are, the compiled ones go to ``_COMPILED``."""
    with _LOCK:
        if _READY.is_set() or _FAILED:
            return
        try:
            numba = import_numba()
            from numba.extending import register_jitable
            for module in KERNEL_MODULES:            # every kernel and helper registered
                importlib.import_module(module)
            _use_cache(numba)
            for fn in _HELPERS:
                register_jitable(fn)
            compiled: dict[str, Callable[..., Any]] = {
                name: numba.njit(cache=True, nogil=True)(fn) for name, fn in _KERNELS.items()}
            _run_each(compiled)
        except Exception as exc:  # noqa: BLE001 - the reference runs instead, and says why
            _FAILED.append(f'{type(exc).__name__}: {exc}')
            return
        _COMPILED.update(compiled)
        _READY.set()


def import_numba() -> Any:
    """numba, for the kernels (module docstring): imported without ``coverage`` unless a
    coverage is running, and ``numba.np.arraymath`` imported with its BLAS probe answered no.
    Both stand-ins are taken back at once (numba's ``ensure_blas`` under numba's compiler lock,
    so no compile in another thread meets it).

    Raises:
        ImportError: numba is not installed.
    """
    import sys

    from pam_bench.vocabulary.imports import import_without
    numba = import_without('numba', 'coverage')
    if 'numba.np.arraymath' not in sys.modules:
        from numba.core.compiler_lock import global_compiler_lock
        from numba.np import linalg

        def no_blas() -> None:
            raise ImportError('the compiled core compiles np.dot without BLAS')

        with global_compiler_lock:
            probe = linalg.ensure_blas
            linalg.ensure_blas = no_blas
            try:
                importlib.import_module('numba.np.arraymath')
            finally:
                linalg.ensure_blas = probe
    return numba


def sources_key() -> str:
    """A digest of the kernels' source files: numba checks only the file of the function it
    caches, and a kernel compiles in helpers of the other modules, so each version of the
    sources gets a cache folder of its own (``cache_dir() / sources_key()``)."""
    import hashlib
    digest = hashlib.sha1(usedforsecurity=False)
    for module in KERNEL_MODULES:
        spec = importlib.util.find_spec(module)
        if spec is not None and spec.origin:
            digest.update(pathlib.Path(spec.origin).read_bytes())
    return digest.hexdigest()[:16]


def _use_cache(numba: Any) -> None:
    """Point numba's cache at this version of the kernels' sources (``sources_key``)."""
    where = pathlib.Path(os.environ['NUMBA_CACHE_DIR']) / sources_key()
    setattr(numba.config, 'CACHE_DIR', str(where))  # noqa: B010


def _run_each(compiled: dict[str, Callable[..., Any]]) -> None:
    """Call every kernel once with its example's arguments (compiles or loads it)."""
    for name, fn in compiled.items():
        fn(*_EXAMPLES[name]())


def warm_up() -> float:
    """Compile (or load from the cache) every kernel now; returns the seconds it took.

    Raises:
        RuntimeError: numba cannot compile them (the message says why).
    """
    t0 = time.perf_counter()
    _load()
    if _FAILED:
        raise RuntimeError(f'the compiled core does not load: {_FAILED[0]}')
    return time.perf_counter() - t0


_FUNCTIONS: dict[Callable[..., Any], tuple[Callable[..., Any] | None, str]] = {}


def compile_function(fn: Callable[..., Any], example: tuple[Any, ...]
                     ) -> tuple[Callable[..., Any] | None, str]:
    """``fn`` compiled by numba in nopython mode (cached in ``cache_dir`` when its module is a
    file), called once with ``example``; (None, why) when it is not: the reference core is
    asked for, numba does not load, or it cannot type ``fn`` (numba's reason). The plain
    Python functions ``fn`` calls (its module's helpers, a function of another module it
    names) are compiled into it (``register_jitable``; they stay what they are for Python).
    Memoised per function: a lab's plug-in law is compiled once per process.
    """
    if fn in _FUNCTIONS:
        return _FUNCTIONS[fn]
    if not _WANTED:
        out: tuple[Callable[..., Any] | None, str] = (None, 'the reference core runs '
                                                     '(PAM_BENCH_CORE=python)')
    else:
        try:
            numba = import_numba()
            _use_cache(numba)
            _callees_jitable(fn, set())
            try:
                compiled = _cached(numba, fn, example)
            except Exception:  # noqa: BLE001 - not cacheable (no file): compiled, uncached
                compiled = numba.njit(fn)
                compiled(*example)
            out = (compiled, '')
        except Exception as exc:  # noqa: BLE001 - runs interpreted, and says why
            out = (None, f'numba cannot compile it: {_reason(exc)}')
    _FUNCTIONS[fn] = out
    return out


def _cached(numba: Any, fn: Callable[..., Any], example: tuple[Any, ...]) -> Any:
    """``fn`` compiled with numba's cache and called once with ``example``. An entry of that
    cache that no longer loads (numba keys it by the file and the function's name; the same
    file imported under another module name, as a test may load a lab's file, leaves an
    entry whose module this process cannot import) is written again rather than bypassed:
    else every later run would compile the function anew (1.1-1.3 s for the example law)."""
    from numba.core.errors import NumbaError
    compiled = numba.njit(cache=True)(fn)
    try:
        compiled(*example)
    except NumbaError:                   # numba's own verdict on fn: no cache makes it good
        raise
    except Exception:  # noqa: BLE001 - a stale entry: this function's index rewritten
        compiled._cache.flush()
        compiled = numba.njit(cache=True)(fn)
        compiled(*example)
    return compiled


def _callees_jitable(fn: Callable[..., Any], seen: set[int]) -> None:
    """Register with numba every plain Python function ``fn`` names (a global of its module,
    or an attribute of a module it names), and theirs in turn."""
    import types

    from numba.extending import register_jitable
    code = getattr(fn, '__code__', None)
    if code is None or id(fn) in seen:
        return
    seen.add(id(fn))
    names = set(code.co_names)
    for name in names:
        obj = fn.__globals__.get(name)
        found = [obj] if isinstance(obj, types.FunctionType) else []
        if isinstance(obj, types.ModuleType):
            found = [getattr(obj, n) for n in names
                     if isinstance(getattr(obj, n, None), types.FunctionType)]
        for callee in found:
            if getattr(callee, '__module__', '').startswith(('numpy', 'numba')):
                continue
            _callees_jitable(callee, seen)
            register_jitable(callee)


def _reason(exc: Exception) -> str:
    """Numba's reason in one line: its first specific line ('No implementation ...',
    'Untyped global name ...'), else the first."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    specific = [line for line in lines if not line.startswith(('Failed in', '- Resolution',
                                                                 'During:', 'File '))]
    return f'{type(exc).__name__}: {(specific or lines or [""])[0]}'[:300]

