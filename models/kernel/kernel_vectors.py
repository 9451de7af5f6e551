"""Word layouts of the kernel's pipelined datapaths and the golden model evaluated on them.

The generated RTL modules (``rtl/pgs_contact_pipe.sv``, ``rtl/pgs_friction_pipe.sv``,
``rtl/pgs_integrate_pipe.sv``) take one manifold (or body) per cycle as a flat list of format words.
This module packs those word lists from the solver's data structures, evaluates the golden model
(:func:`models.golden.contact_solver.contact_solve`, :func:`models.golden.contact_solver.friction_solve`,
:func:`models.golden.integrator.integrate`, unchanged) on them, and collects realistic inputs from a
sequential golden solve of a scene (the velocities and impulses each manifold-pass really sees).

Layouts (word k of ``in_data`` / ``out_data``):

* contact in (53): 0-2 n; 3-14 p[0..3] (p0.x, p0.y, p0.z, p1.x, ...); 15-18 jac_inv; 19-22 b; 23-26 lam;
  27-29 xA; 30-32 xB; 33-35 vA; 36-38 wA; 39-41 vB; 42-44 wB; 45 mInvA; 46 mInvB; 47-49 IInvA;
  50-52 IInvB. Out (16): 0-3 lam; 4-6 vA; 7-9 wA; 10-12 vB; 13-15 wB.
* friction in (46): 0-2 n; 3-5 c; 6-8 t0; 9-11 t1; 12-13 f_jac_inv; 14-17 lam_n; 18-19 lamT; 20-22 xA;
  23-25 xB; 26-28 vA; 29-31 wA; 32-34 vB; 35-37 wB; 38 mInvA; 39 mInvB; 40-42 IInvA; 43-45 IInvB;
  plus the spin_damp flag. Out (14): 0-1 lamT; 2-4 vA; 5-7 wA; 8-10 vB; 11-13 wB.
* integrate in (18): 0-2 pos; 3-6 q (x, y, z, w); 7-9 v; 10-12 w; 13 dt; 14 damping; 15-17 g.
  Out (13): 0-2 pos; 3-6 q; 7-9 v; 10-12 w.

The contact and friction layouts above are those of the kernel's build (3 inverse-inertia words per body). In the
other inverse-inertia modes (``inertia_words`` 1 or 6, ``rtl.gen.kernel_graphs``) IInvA and IInvB take 1 or 6
words each (6: xx, yy, zz, xy, xz, yz) and the words after them move; with ``manifold_friction`` the friction
layout ends with the manifold's coefficient mu.

Velocities of a static body (inverse mass 0) are returned as the golden computes them in its
gathered state (the solver never writes them back), which is what the RTL computes too.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from models.setup.constraints import FRICTION_COEFF, BodyTable, ConstraintSet
from models.golden.contact_solver import (CONTACT_PASS, Impulses, SolverParams, _Gathered, contact_solve,
                                          friction_solve, solve)
from models.setup.inertia import inertia_mode
from models.golden.integrator import ANGULAR_DAMPING, IntegrationParams, integrate
from models.formats.number_format import Arithmetic

CONTACT_N_OUT = 16
FRICTION_N_OUT = 14


def contact_n_in(inertia_words: int = 3) -> int:
    return 47 + 2 * inertia_words


def friction_n_in(inertia_words: int = 3, manifold_friction: bool = False) -> int:
    return 40 + 2 * inertia_words + int(manifold_friction)


CONTACT_N_IN = contact_n_in()
FRICTION_N_IN = friction_n_in()
INTEGRATE_N_IN, INTEGRATE_N_OUT = 18, 13

# Body-state fields in the order of the word layouts (both pass kinds).
_BODY_FIELDS = ("xa", "xb", "va", "wa", "vb", "wb")


def _bodies_for_pairs(ba: dict[str, np.ndarray]) -> tuple[BodyTable, np.ndarray, np.ndarray]:
    """A body table holding K (A, B) pairs as bodies 2i, 2i+1."""
    k = ba["xa"].shape[0]

    def inter(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        out = np.empty((2 * k,) + a.shape[1:])
        out[0::2], out[1::2] = a, b
        return out

    bodies = BodyTable(
        position=inter(ba["xa"], ba["xb"]), orientation=np.zeros((2 * k, 4)),
        linear_velocity=inter(ba["va"], ba["vb"]), angular_velocity=inter(ba["wa"], ba["wb"]),
        inv_mass=inter(ba["ma"], ba["mb"]), inv_inertia=inter(_as_table(ba["ia"]), _as_table(ba["ib"])))
    return bodies, np.arange(k) * 2, np.arange(k) * 2 + 1


def _as_table(inertia: np.ndarray) -> np.ndarray:
    """A pipe's inverse-inertia words as the body table holds them (a scalar repeated on the diagonal)."""
    return np.repeat(inertia, 3, axis=1) if inertia.shape[1] == 1 else inertia


def _body_words(w: np.ndarray, base: int, inertia_words: int = 3) -> dict[str, np.ndarray]:
    d = {name: w[:, base + 3 * i: base + 3 * i + 3] for i, name in enumerate(_BODY_FIELDS)}
    d["ma"], d["mb"] = w[:, base + 18], w[:, base + 19]
    lo = base + 20
    d["ia"], d["ib"] = w[:, lo: lo + inertia_words], w[:, lo + inertia_words: lo + 2 * inertia_words]
    return d


def _inertia_words(inertia: np.ndarray, inertia_words: int) -> np.ndarray:
    """A body table's (K, 3) or (K, 6) inverse inertia as ``inertia_words`` pipe words (refused where that
    would drop a value: the rows' mode needs more words)."""
    need = inertia_mode(inertia, np.ones(inertia.shape[0], dtype=bool)).words
    if need > inertia_words:
        raise ValueError(f"the inverse inertia needs {need} words per body, the pipe takes {inertia_words}")
    if inertia_words == 6 and inertia.shape[1] == 3:
        return np.concatenate([inertia, np.zeros((inertia.shape[0], 3))], axis=1)
    return inertia[:, :inertia_words]


def _gathered_words(g: _Gathered, inertia_words: int = 3) -> list[np.ndarray]:
    return [g.xa, g.xb, g.va, g.wa, g.vb, g.wb, g.ma[:, None], g.mb[:, None], _inertia_words(g.ia, inertia_words),
            _inertia_words(g.ib, inertia_words)]


# --- contact -------------------------------------------------------------------------------------
def contact_words(cons: ConstraintSet, idx: np.ndarray, lam: np.ndarray, g: _Gathered,
                  inertia_words: int = 3) -> np.ndarray:
    """(K, 53) input words of manifolds ``idx`` with impulses ``lam`` (K,4) and gathered state ``g``."""
    k = len(idx)
    return np.concatenate([cons.normal[idx], cons.points[idx].reshape(k, 12), cons.jac_inv[idx], cons.bias[idx],
                           lam] + _gathered_words(g, inertia_words), axis=1)


def contact_golden(ar: Arithmetic, words: np.ndarray, inertia_words: int = 3,
                   soft_keep: tuple[float, float] | None = None) -> np.ndarray:
    """(K, 53) input words -> (K, 16) output words of ``contact_solve`` (one manifold per row), with the soft
    contact's keep factors ``soft_keep`` (``SolverParams.soft_keep``) where given."""
    w = np.asarray(words, dtype=np.float64)
    k = w.shape[0]
    bodies, a, b = _bodies_for_pairs(_body_words(w, 27, inertia_words))
    cons = ConstraintSet(
        body_a=a, body_b=b, num_points=np.full(k, 4), normal=w[:, 0:3], points=w[:, 3:15].reshape(k, 4, 3),
        jac_inv=w[:, 15:19], bias=w[:, 19:23], center=np.zeros((k, 3)), tangent=np.zeros((k, 2, 3)),
        f_jac_inv=np.zeros((k, 2)), spin_damp=np.zeros(k, dtype=bool))
    g = _Gathered(bodies, a, b)
    lam = contact_solve(ar, g, cons, np.arange(k), w[:, 23:27], soft_keep)
    return np.concatenate([lam, g.va, g.wa, g.vb, g.wb], axis=1)


# --- friction ------------------------------------------------------------------------------------
def friction_words(cons: ConstraintSet, idx: np.ndarray, lam_n: np.ndarray, lam_t: np.ndarray,
                   g: _Gathered, inertia_words: int = 3,
                   manifold_friction: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """((K, 46) input words, (K,) spin_damp flags) of manifolds ``idx``."""
    k = len(idx)
    mu = [cons.friction[idx]] if manifold_friction else []
    words = np.concatenate([cons.normal[idx], cons.center[idx], cons.tangent[idx].reshape(k, 6), cons.f_jac_inv[idx],
                            lam_n, lam_t] + _gathered_words(g, inertia_words) + mu, axis=1)
    return words, cons.spin_damp[idx].copy()


def friction_golden(ar: Arithmetic, words: np.ndarray, spin_damp: np.ndarray,
                    friction_coeff: float = FRICTION_COEFF, inertia_words: int = 3,
                    manifold_friction: bool = False) -> np.ndarray:
    """(K, 46) input words and (K,) flags -> (K, 14) output words of ``friction_solve``."""
    w = np.asarray(words, dtype=np.float64)
    k = w.shape[0]
    bodies, a, b = _bodies_for_pairs(_body_words(w, 20, inertia_words))
    cons = ConstraintSet(
        body_a=a, body_b=b, num_points=np.full(k, 4), normal=w[:, 0:3], points=np.zeros((k, 4, 3)),
        jac_inv=np.zeros((k, 4)), bias=np.zeros((k, 4)), center=w[:, 3:6], tangent=w[:, 6:12].reshape(k, 2, 3),
        f_jac_inv=w[:, 12:14], spin_damp=np.asarray(spin_damp, dtype=bool),
        friction=w[:, -1:] if manifold_friction else None)
    g = _Gathered(bodies, a, b)
    lam_t = friction_solve(ar, g, cons, np.arange(k), w[:, 14:18], w[:, 18:20], friction_coeff)
    return np.concatenate([lam_t, g.va, g.wa, g.vb, g.wb], axis=1)


# --- integration -----------------------------------------------------------------------------------
def integrate_words(bodies: BodyTable, idx: np.ndarray, dt: float, damping: float,
                    gravity: np.ndarray) -> np.ndarray:
    """(K, 18) input words of bodies ``idx`` (dt, damping, g per row)."""
    k = len(idx)
    return np.concatenate([bodies.position[idx], bodies.orientation[idx], bodies.linear_velocity[idx],
                           bodies.angular_velocity[idx], np.full((k, 1), dt), np.full((k, 1), damping),
                           np.broadcast_to(np.asarray(gravity, dtype=np.float64), (k, 3))], axis=1)


def integrate_golden(ar: Arithmetic, words: np.ndarray) -> np.ndarray:
    """(K, 18) input words -> (K, 13) output words of ``integrate`` (each row a dynamic body).

    Rows are grouped by their (dt, damping, g), which ``integrate`` takes as run parameters."""
    w = np.asarray(words, dtype=np.float64)
    out = np.empty((w.shape[0], INTEGRATE_N_OUT))
    keys = np.ascontiguousarray(w[:, 13:18]).view(np.uint64)
    _, inverse = np.unique(keys, axis=0, return_inverse=True)
    for grp in range(int(inverse.max()) + 1 if w.shape[0] else 0):
        rows = np.flatnonzero(inverse.ravel() == grp)
        r0 = w[rows[0]]
        k = len(rows)
        bodies = BodyTable(position=w[rows, 0:3], orientation=w[rows, 3:7], linear_velocity=w[rows, 7:10],
                           angular_velocity=w[rows, 10:13], inv_mass=np.ones(k), inv_inertia=np.ones((k, 3)))
        params = IntegrationParams(dt=float(r0[13]), gravity=(float(r0[15]), float(r0[16]), float(r0[17])),
                                   damping=float(r0[14]))
        res = integrate(bodies, ar, params)
        out[rows] = np.concatenate([res.position, res.orientation, res.linear_velocity, res.angular_velocity],
                                   axis=1)
    return out


# --- realistic inputs from a sequential golden solve ----------------------------------------------------
@dataclass
class SceneVectors:
    contact: np.ndarray   # (Kc, 53)
    friction: np.ndarray  # (Kf, 46)
    spin_damp: np.ndarray  # (Kf,)
    integrate: np.ndarray  # (Kb, 18)


def scene_vectors(bodies: BodyTable, cons: ConstraintSet, ar: Arithmetic, params: SolverParams = SolverParams(),
                  dt: float = 1.0 / 60.0, gravity: tuple[float, float, float] = (0.0, -9.8, 0.0),
                  damping: float = ANGULAR_DAMPING, schedule: np.ndarray | None = None,
                  inertia_words: int = 3, initial: Impulses | None = None,
                  record_checks: Sequence[bool] | None = None) -> SceneVectors:
    """The inputs of every manifold-pass of a golden solve (:func:`models.golden.contact_solver.solve` with an input
    sink: manifolds in ``schedule`` order, default index order; from the impulses ``initial``, zeros when None;
    without the manifold-passes the kernel rejects under ``record_checks``, ``KernelJob.record_checks``), and of
    the integration of every dynamic body afterwards. ``bodies``/``cons`` must be in the format; the friction
    words end with mu where ``cons`` carries a coefficient per manifold."""
    mu = cons.per_manifold_friction
    cw, fw, fs = [], [], []

    def collect(kind: int, idx: np.ndarray, g: _Gathered, imp: Impulses) -> None:
        if kind == CONTACT_PASS:
            cw.append(contact_words(cons, idx, imp.normal[idx], g, inertia_words))
        else:
            words, spin = friction_words(cons, idx, imp.normal[idx], imp.friction[idx], g, inertia_words, mu)
            fw.append(words)
            fs.append(spin)

    order = np.arange(cons.num_manifolds) if schedule is None else schedule
    out = solve(bodies, cons, order, ar, params, initial=initial, record_checks=record_checks,
                inputs=collect).bodies
    dyn = np.flatnonzero(out.dynamic)
    iw = integrate_words(out, dyn, float(ar.const(dt)), float(ar.const(damping)), ar.const(np.asarray(gravity)))
    empty = lambda n: np.zeros((0, n))  # noqa: E731
    return SceneVectors(
        contact=np.concatenate(cw) if cw else empty(contact_n_in(inertia_words)),
        friction=np.concatenate(fw) if fw else empty(friction_n_in(inertia_words, mu)),
        spin_damp=np.concatenate(fs) if fs else np.zeros(0, dtype=bool),
        integrate=iw)
