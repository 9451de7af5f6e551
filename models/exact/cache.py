"""The exact reference cached beside its frame: computed once per frame and scheme, written atomically.

The reference (``models/exact/reference.py``) depends only on the step's float64 body table and constraints
(themselves a function of the frame) and on the scheme's settings that change its limit (friction coefficient,
pass order), plus the solver and its tolerance; not on the number format, the schedule or the iteration count.
The cache file ``<dir>/exact_<key>.npz`` is keyed by a SHA-256 over exactly those; it is written under a
temporary name and renamed into place, so a reader never sees half a file. A file that cannot be read (corrupt,
truncated, another version) is recomputed and replaced. A failed attempt (``ExactReferenceError``) is recorded in
``exact_<key>.failed.json`` with its budget, so that later runs with no larger budget report the reason at once
instead of spending the budget again (delete the file to retry).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from dataclasses import fields
from pathlib import Path

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses, SolverParams
from models.exact import large_island
from models.exact.phases import DIRECT_ROWS_LIMIT, PIVOT_TARGET, SOLVER_TOLERANCE, Budget
from models.exact.reference import ExactReference, ExactReferenceInterrupted, exact_reference_bounded
from models.exact.assembly import ExactReferenceError
from models.exact.large_island import ITERATIVE_TOLERANCE

CACHE_VERSION = 3  # bump whenever the reference computation changes
_VELOCITIES = ("contact_linear", "contact_angular", "linear", "angular", "normal", "friction")


def cache_key(bodies: BodyTable, cons: ConstraintSet, params: SolverParams) -> str:
    """SHA-256 (16 hex digits) of the step's content and the settings that change its limit."""
    h = hashlib.sha256()
    for table in (bodies, cons):
        for f in fields(table):
            arr = np.ascontiguousarray(getattr(table, f.name))
            h.update(f"{f.name}:{arr.dtype.str}:{arr.shape}".encode())
            h.update(arr.tobytes())
    import importlib.metadata

    settings = {"friction_coeff": params.friction_coeff, "interleaved": params.interleaved,
                "solver": "clarabel " + importlib.metadata.version("clarabel"),
                "tolerance": SOLVER_TOLERANCE, "version": CACHE_VERSION,
                "iterative": [DIRECT_ROWS_LIMIT, ITERATIVE_TOLERANCE]}
    settings.update(_later_settings(bodies, cons, params))
    h.update(json.dumps(settings, sort_keys=True).encode())
    return h.hexdigest()[:16]


def _later_settings(bodies: BodyTable, cons: ConstraintSet, params: SolverParams) -> dict[str, str]:
    """Key entries only for problems whose reference the version-3 computation got wrong or refused, so that the
    keys (and cached references) of every other problem stay as they were: a full 3x3 inverse inertia (refused
    before, then solved by Newton from the convex QP's solution, which gave up on stacked turned blocks: a failure
    may be recorded under the older keys), per-manifold friction coefficients (solved with ``params.friction_coeff``
    before), the interleaved order (refused before), and every problem without an island above
    ``DIRECT_ROWS_LIMIT`` (fewer active contact points than that) since the contact phase's components above
    ``PIVOT_TARGET`` are re-solved by pivoting (the thesis frame's key, and its reference, stay)."""
    out = {}
    if bodies.inv_inertia.shape[1] == 6:
        out["inertia"] = ("full 3x3, damping off the eigenvectors as a non-symmetric box problem from the kernel's "
                          "start: Gauss-Seidel, Newton, pivoting")
    if int(np.count_nonzero(cons.jac_inv)) <= DIRECT_ROWS_LIMIT:
        out["contact polish"] = f"components above {PIVOT_TARGET:g} m/s re-solved by pivoting"
    if cons.per_manifold_friction:
        out["friction"] = "per manifold"
    if params.interleaved:
        out["interleaved"] = "coupled fixed point by alternation"
    return out


def cache_path(cache_dir: str | os.PathLike[str], key: str) -> Path:
    return Path(cache_dir) / f"exact_{key}.npz"


def save_reference(ref: ExactReference, path: Path) -> None:
    """Write atomically: a temporary file in the same directory, renamed into place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    arrays = {"contact_linear": ref.contact_bodies.linear_velocity, "contact_angular": ref.contact_bodies.angular_velocity,
              "linear": ref.bodies.linear_velocity, "angular": ref.bodies.angular_velocity,
              "normal": ref.impulses.normal, "friction": ref.impulses.friction}
    meta = {"version": CACHE_VERSION, "residuals": ref.residuals, "seconds": ref.seconds, "islands": ref.islands,
            "solver": ref.solver, "details": ref.details}
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp.npz", dir=path.parent)
    os.close(fd)
    try:
        np.savez(tmp, meta_json=np.array(json.dumps(meta)), **arrays)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def load_reference(path: Path, bodies: BodyTable) -> ExactReference | None:
    """The cached reference, or None when the file is missing or unusable (wrong version, shapes, corrupt)."""
    if not path.is_file():
        return None
    try:
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta_json")))
    except Exception:  # a corrupt or truncated file: recompute
        return None
    n = bodies.num_bodies
    if meta.get("version") != CACHE_VERSION or any(k not in arrays for k in _VELOCITIES):
        return None
    m = arrays["normal"].shape[0]
    shapes = {"contact_linear": (n, 3), "contact_angular": (n, 3), "linear": (n, 3), "angular": (n, 3),
              "normal": (m, 4), "friction": (m, 2)}
    if any(arrays[k].shape != s for k, s in shapes.items()):
        return None

    def with_v(lin: np.ndarray, ang: np.ndarray) -> BodyTable:
        out = bodies.copy()
        out.linear_velocity, out.angular_velocity = lin.astype(np.float64), ang.astype(np.float64)
        return out

    return ExactReference(with_v(arrays["contact_linear"], arrays["contact_angular"]),
                          with_v(arrays["linear"], arrays["angular"]),
                          Impulses(arrays["normal"].astype(np.float64), arrays["friction"].astype(np.float64)),
                          meta["residuals"], meta["seconds"], int(meta["islands"]), str(meta["solver"]),
                          meta.get("details", {}))


def cached_exact_reference(bodies: BodyTable, cons: ConstraintSet, cache_dir: str | os.PathLike[str],
                           params: SolverParams = SolverParams(),
                           budget: Budget = Budget()) -> tuple[ExactReference, Path, bool]:
    """(reference, its cache file, whether it came from the cache); computes and stores it when absent.

    Raises :class:`~models.exact.reference.ExactReferenceError` when it cannot be computed (nothing is written)."""
    path = cache_path(cache_dir, cache_key(bodies, cons, params))
    ref = load_reference(path, bodies)
    if ref is not None and ref.impulses.normal.shape[0] == cons.num_manifolds:
        return ref, path, True
    failed = path.with_suffix(".failed.json")
    earlier = _recorded_failure(failed)
    if (earlier is not None and earlier["time_s"] >= budget.time_s and earlier["memory_bytes"] >= budget.memory_bytes
            and earlier.get("large_island_method") == large_island.LARGE_ISLAND_METHOD):
        raise ExactReferenceError(f"{earlier['reason']} (recorded by an earlier attempt with a budget of "
                                  f"{earlier['time_s']:.0f} s; a larger budget, make's EXACT_BUDGET, tries again)")
    t0 = time.perf_counter()
    try:
        ref = exact_reference_bounded(bodies, cons, params, budget)
    except ExactReferenceInterrupted:
        raise
    except ExactReferenceError as exc:
        _write_atomically(failed, json.dumps({"reason": str(exc), "time_s": budget.time_s,
                                              "memory_bytes": budget.memory_bytes,
                                              "large_island_method": large_island.LARGE_ISLAND_METHOD}).encode())
        raise
    ref.seconds["total"] = time.perf_counter() - t0
    save_reference(ref, path)
    if failed.exists():
        failed.unlink()
    return ref, path, False


def _recorded_failure(path: Path) -> dict | None:
    try:
        rec = json.loads(path.read_text())
        return rec if {"reason", "time_s", "memory_bytes"} <= set(rec) else None
    except (OSError, ValueError):
        return None


def _write_atomically(path: Path, data: bytes) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name, suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
