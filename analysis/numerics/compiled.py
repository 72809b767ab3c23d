"""CasADi Functions mapped over many points and compiled to C, cached on disk between runs.

:func:`compiled_map` generates C for a Function mapped over ``m`` points (the loop inside the C code),
compiles it once per machine with the C compiler :func:`compiler` finds, and loads it as a CasADi external
Function; the shared library is kept under the hash of its source, compiler and flags
(``$AUTOBAL_CACHE``, else ``$XDG_CACHE_HOME/autobal`` or ``~/.cache/autobal``), so a later process only
loads it.  Without a compiler, or when compiling fails, it returns None and the caller keeps CasADi's
virtual machine, with the same results.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import casadi as ca

# no -ffast-math, no -march: the virtual machine's floating-point results, bit for bit; -fno-semantic-interposition
# lets the compiler inline CasADi's helpers (fmax, fabs, sq) into the loop (1.3x)
COMPILER_FLAGS = ("-O2", "-fPIC", "-shared", "-fno-semantic-interposition", "-fno-math-errno")


def compiler() -> str | None:
    """The C compiler of the compiled maps.

    Returns
    -------
    str or None
        ``$CC``, else ``cc`` or ``gcc`` on the path; None (CasADi's virtual machine is used) when there
        is none or the environment sets ``AUTOBAL_COMPILE=0``.
    """
    if os.environ.get("AUTOBAL_COMPILE", "1") == "0":
        return None
    return os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")


def _cache_dir() -> Path:
    """Where compiled maps are kept between runs: ``$AUTOBAL_CACHE``, else ``$XDG_CACHE_HOME/autobal`` or
    ``~/.cache/autobal``, subfolder ``compiled``."""
    xdg = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    root = os.environ.get("AUTOBAL_CACHE") or Path(xdg) / "autobal"
    return Path(root) / "compiled"


_FAILED: set = set()  # keys of the maps this process could not compile (not tried again)


def compiled_map(f: ca.Function, m: int, parallel: str = "serial", threads: int = 2) -> ca.Function | None:
    """``f`` mapped over ``m`` points as C code with the loop inside, compiled once per machine and loaded as a
    CasADi external Function: the shared library is cached on disk under the hash of its C source, compiler
    and flags, so a second process only loads it.  Compiled without fast-math or machine-specific flags, it
    gives the virtual machine's results bit for bit.

    Parameters
    ----------
    f : casadi.Function
        One point's Function (dense column inputs and outputs).
    m : int
        Points per call: inputs and outputs are (entries x m), one point a column.
    parallel : {"serial", "thread", "openmp"}
        CasADi's map mode in the generated code (POSIX threads or OpenMP over ``threads`` threads).
    threads : int
        Threads of a parallel map.

    Returns
    -------
    casadi.Function or None
        The compiled map; None when no C compiler is found or compiling fails (the caller then uses
        CasADi's virtual machine, with the same results).
    """
    cc = compiler()
    if cc is None:
        return None
    ins = [ca.MX.sym(f.name_in(i), f.size1_in(i), m) for i in range(f.n_in())]
    name = f"{f.name()}_map{m}" + ("" if parallel == "serial" else f"_{parallel}{threads}")
    mapped = f.map(m) if parallel == "serial" else f.map(m, parallel, threads)
    cg = ca.CodeGenerator(f"{name}.c")
    cg.add(ca.Function(name, ins, mapped.call(ins), [f"i{i}" for i in range(f.n_in())],
                       [f"o{j}" for j in range(f.n_out())]))
    source = cg.dump()
    flags = [*COMPILER_FLAGS] + {"serial": [], "thread": ["-pthread"], "openmp": ["-fopenmp"]}[parallel]
    key = hashlib.sha256("\0".join([source, cc, *flags]).encode()).hexdigest()[:20]
    if key in _FAILED:
        return None
    lib = _cache_dir() / f"{name}_{key}.so"
    if not lib.exists():
        try:
            lib.parent.mkdir(parents=True, exist_ok=True)
            with tempfile.TemporaryDirectory(dir=lib.parent) as tmp:
                src, out = Path(tmp) / f"{name}.c", Path(tmp) / lib.name
                src.write_text(source)
                subprocess.run([cc, *flags, str(src), "-o", str(out), "-lm"], check=True,
                               capture_output=True, timeout=120)
                os.replace(out, lib)  # atomic: a concurrent process sees no half-written library
        except (OSError, subprocess.SubprocessError):
            _FAILED.add(key)
            return None
    return ca.external(name, str(lib))
