"""What a point needs on the worker that runs it: kernel builds and frames, each found by a hash.

* :class:`KernelStore`: the compiled kernel harness of a :class:`sim.compile.kernel_build.KernelBuild`, in
  ``<root>/<build name>-<key>/`` where the key is a hash of the build description (:func:`build_key`: the Verilator
  binary and the build's keywords, ``sim.compile.kernel_build.kernel_build_args``, with every source and harness file by
  content). A missing build is made in a temporary directory beside
  it and renamed into place (an atomic rename, also on NFS): several hosts sharing the store may build the same key
  at once, the first rename wins and the others use it. Within one host, a lock in the host's own temp directory
  (never on the store) makes the other processes wait, so each key is built once per host. The root is
  ``$PGS_KERNEL_STORE``, else ``build/kernels`` of the checkout the code runs from: per host when each host has its
  own checkout, shared when the checkout is on a shared file system.
* :class:`FrameStore`: frames by the hash of their file's bytes, in ``build/frames/by-hash/<sha256>.npz`` under the
  worker's working directory. A point names its frame by hash; a worker without it raises :class:`MissingArtefact`
  and the driver sends the bytes with the point again (``sim.parallel.executor``).
* :func:`source_digest`: a hash of the code and RTL a point's result depends on, part of every point's key so that
  a results file never resumes from rows of other sources.
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from models.formats.frame import Frame, load, save
from sim.compile.kernel_build import KernelBuild, kernel_build_args, verilate_kernel
from sim.compile.verilator_build import REPO_ROOT, inputs_digest

FRAME_DIR = Path("build") / "frames" / "by-hash"  # relative to the working directory, like build/frames
# the sources a point's result depends on (test files excluded)
DIGEST_GLOBS = ("models/**/*.py", "sim/**/*.py", "sim/harness/*", "rtl/**/*.sv", "rtl/**/*.f", "rtl/**/*.json",
                "rtl/gen/**/*.py", "hls_export/*.py")


class MissingArtefact(LookupError):
    """The worker lacks an artefact the driver can send (``digest`` names it)."""

    def __init__(self, digest: str):
        super().__init__(f"artefact {digest} is not on this worker")
        self.digest = digest


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


@lru_cache(maxsize=1)
def source_digest() -> str:
    """A hash of every model, simulator and RTL source (first 16 hex digits)."""
    h = hashlib.sha256()
    for pattern in DIGEST_GLOBS:
        for path in sorted(REPO_ROOT.glob(pattern)):
            if path.is_file() and "tests" not in path.relative_to(REPO_ROOT).parts:
                h.update(str(path.relative_to(REPO_ROOT)).encode() + b"\0" + path.read_bytes())
    return h.hexdigest()[:16]


def frame_bytes(frame: Frame) -> bytes:
    """The bytes of ``frame``'s file (``models.formats.frame.save``), the form frames travel and are hashed in."""
    with tempfile.TemporaryDirectory() as tmp:
        return save(frame, Path(tmp) / "frame.npz").read_bytes()


@dataclass(frozen=True)
class FrameStore:
    """Frames by content hash under ``root`` (default: ``build/frames/by-hash`` of the working directory)."""

    root: Path = FRAME_DIR

    def path(self, digest: str) -> Path:
        return Path(self.root) / f"{digest}.npz"

    def put(self, data: bytes) -> str:
        """Store a frame file's bytes (written under a temporary name, renamed into place); return its hash."""
        digest = sha256_bytes(data)
        path = self.path(digest)
        if not path.is_file():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{digest[:12]}-", suffix=".tmp", dir=path.parent)
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        return digest

    def has(self, digest: str) -> bool:
        return self.path(digest).is_file()

    def get(self, digest: str) -> Frame:
        """The frame of ``digest``; :class:`MissingArtefact` when absent or when its bytes no longer match."""
        path = self.path(digest)
        if not path.is_file() or sha256_bytes(path.read_bytes()) != digest:
            path.unlink(missing_ok=True)
            raise MissingArtefact(digest)
        return load(path)


def kernel_store_root() -> Path:
    env = os.environ.get("PGS_KERNEL_STORE")
    return Path(env) if env else REPO_ROOT / "build" / "kernels"


def build_key(kb: KernelBuild) -> str:
    """A hash of ``kb``'s build (first 16 hex digits): its ``build`` keywords with every input file by content,
    and the Verilator binary (``sim.compile.verilator_build.inputs_digest``)."""
    return inputs_digest(kernel_build_args(kb))[:16]


@dataclass(frozen=True)
class KernelStore:
    """Kernel harness builds by build key under ``root`` (:func:`kernel_store_root`)."""

    root: Path

    def executable(self, kb: KernelBuild) -> tuple[Path, float]:
        """The executable of ``kb``, building it once per host when absent; returns it and the seconds this call
        spent building (0 when found)."""
        final = Path(self.root) / f"{kb.name}-{build_key(kb)}"
        exe = final / kb.name
        if exe.is_file():
            return exe, 0.0
        lock_path = Path(tempfile.gettempdir()) / f"pgs-kernel-{final.name}.lock"  # host-local, never the store
        with lock_path.open("w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if exe.is_file():  # another process on this host built it meanwhile
                return exe, 0.0
            t0 = time.monotonic()
            final.parent.mkdir(parents=True, exist_ok=True)
            tmp = Path(tempfile.mkdtemp(prefix=f".{final.name}-", dir=final.parent))
            try:
                verilate_kernel(kb, build_dir=tmp, lock=False)
                try:
                    tmp.rename(final)
                except OSError:  # another host renamed its build into place first: use that one
                    if not exe.is_file():
                        raise
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
            return exe, time.monotonic() - t0
