"""The kernel's source list, ``rtl/pgs_kernel.f``: every SystemVerilog file of ``pgs_kernel`` in compile order
(packages first), one path a line relative to the list's folder (Verilator reads it with ``-F rtl/pgs_kernel.f``;
``//`` starts a comment). Lint, every Verilator build of the kernel and the Yosys estimate read it through
:func:`kernel_sources`.

A test build with an injected bug swaps one file for a variant generated into a build directory
(:func:`swap_sources`; ``rtl.gen.friction_sign_bug_sources``).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from pathlib import Path

from rtl.gen.repo_paths import REPO_ROOT

RTL_DIR = REPO_ROOT / "rtl"
KERNEL_FILE_LIST = RTL_DIR / "pgs_kernel.f"
_PACKAGE_RE = re.compile(r"^\s*package\s+\w+", re.MULTILINE)


class FileListError(ValueError):
    """A file list that names a missing file, a file twice, or something other than a source path."""


def read_file_list(path: Path = KERNEL_FILE_LIST) -> list[Path]:
    """The absolute paths a file list names, in its order (each checked to exist, none twice)."""
    out: list[Path] = []
    for number, raw in enumerate(path.read_text().splitlines(), start=1):
        line = raw.split("//", 1)[0].strip()
        if not line:
            continue
        where = f"{path}:{number}"
        if line.startswith(("-", "+")) or len(line.split()) != 1:
            raise FileListError(f"{where}: {line!r} is not a single source path (no options in the list)")
        source = (path.parent / line).resolve()
        if not source.is_file():
            raise FileListError(f"{where}: {line} does not exist")
        if source in out:
            raise FileListError(f"{where}: {line} is listed twice")
        out.append(source)
    if not out:
        raise FileListError(f"{path} lists no source")
    return out


def kernel_sources() -> list[Path]:
    """The kernel's sources in compile order (``rtl/pgs_kernel.f``)."""
    return read_file_list(KERNEL_FILE_LIST)


def swap_sources(sources: Sequence[Path], replacements: Sequence[Path]) -> list[Path]:
    """``sources`` with each file replaced by the replacement of the same file name (the same module), in place."""
    by_name = {p.name: Path(p) for p in replacements}
    unknown = set(by_name) - {p.name for p in sources}
    if unknown:
        raise FileListError(f"no source to replace with {sorted(unknown)}")
    return [by_name.get(p.name, Path(p)) for p in sources]


def rtl_files(sources: Sequence[Path] | None = None) -> tuple[list[Path], list[Path]]:
    """(package files, module files) of ``sources`` (default: the kernel's, ``rtl/pgs_kernel.f``), in list order."""
    files = list(kernel_sources() if sources is None else sources)
    packages = [f for f in files if _PACKAGE_RE.search(f.read_text())]
    modules = [f for f in files if f not in packages]
    return packages, modules
