"""The exact reference on many worlds: per world the bodies, manifolds, the method that solved the friction phase, the
largest natural residual and the seconds, or the one-line reason there is none.

    python -m sim.studies.exact_survey --seeds 0-29                      # the random worlds
    (models/scenes/random_world.py)
    python -m sim.studies.exact_survey --scenes builtin,assets --seeds ""  # every built-in scene and the asset scenes
    python -m sim.studies.exact_survey --scenes docs/jenga_heap_world.py --seeds ""

Each reference is computed afresh (not read from the cache) with ``exact_reference_bounded`` under ``--budget``
seconds (default 60) and 8 GiB; the frames come from the frame cache (``build/frames/``) or are captured. The last
line sums up: how many worlds have a reference, the largest residual and the slowest solve. Exit status 1 when a
world has none (``--allow-missing`` to report only).
"""

from __future__ import annotations

import argparse
import time
from dataclasses import dataclass
from typing import Sequence

from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.exact.phases import Budget
from models.exact.reference import ExactReference, exact_reference_bounded
from models.exact.assembly import ExactReferenceError
from models.exact.damped_friction import DAMPED_KEY, METHODS, not_certified_unique
from models.scenes.random_world import parse_seeds
from models.scenes.specs import SCENES

RESIDUAL_KEYS = ("contact phase: normal LCP |min(lam K, e)| max (m/s)", "friction phase: box residual max (m/s)",
                 "friction phase: spin |n.w| max (rad/s)")
SHORT = {METHODS[0]: "Gauss-Seidel", METHODS[1]: "Newton", METHODS[2]: "pivoting (warm)",
         METHODS[3]: "pivoting (cold)", METHODS[4]: "proximal point",
         METHODS[5]: "MPRGP"}


@dataclass
class SurveyRow:
    world: str
    bodies: int
    manifolds: int
    method: str
    residual: float | None
    seconds: float
    reason: str = ""


def friction_method(ref: ExactReference) -> str:
    """How the friction phase was solved: the convex QP, or the damped problem's methods with their component
    counts (and whether every component is certified unique)."""
    d = ref.details
    used = [f"{SHORT[name]} {int(d[k])}" for name in METHODS
            if (k := f"{DAMPED_KEY} components solved by {name}") in d and d[k]]
    if not used:
        return "QP" + (" (large island, certified)" if any("certified" in k for k in d) else "")
    return ", ".join(used) + ("; not certified unique" if not_certified_unique(d) else "; unique")


def survey_world(scene: str, scene_args: str, budget_s: float) -> SurveyRow:
    frame, label = scenes.load_scene(scene, scene_args, seed=1)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    t0 = time.perf_counter()
    try:
        ref = exact_reference_bounded(bodies, cons, budget=Budget(time_s=budget_s))
    except ExactReferenceError as exc:
        return SurveyRow(label, frame.num_bodies, frame.num_manifolds, "none", None, time.perf_counter() - t0,
                         str(exc))
    seconds = time.perf_counter() - t0
    residual = max(ref.residuals[k] for k in RESIDUAL_KEYS)
    return SurveyRow(label, frame.num_bodies, frame.num_manifolds, friction_method(ref), residual, seconds)


def worlds(which: str, seeds: str) -> list[tuple[str, str]]:
    """(scene, SCENE_ARGS) of every world asked for."""
    out: list[tuple[str, str]] = []
    for item in (w.strip() for w in which.split(",") if w.strip()):
        if item == "builtin":
            out += [(s, "") for s in SCENES if s != "thesis"]
        elif item == "assets":
            out += [(s, "") for s in scenes.ASSET_SCENES if s != "random_world"]
        else:
            out.append((item, ""))
    if seeds:
        out += [("random_world", f"seed={s}") for s in parse_seeds(seeds)]
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.exact_survey", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="", help="comma-separated: builtin (every built-in scene but thesis), assets "
                                                 "(jenga_tower, duck_lego_pile), scene names or world files")
    ap.add_argument("--seeds", default="0-29", help="random_world seeds (a-b or a,b,c; empty: none)")
    ap.add_argument("--budget", type=float, default=60.0, help="seconds allowed per exact reference")
    ap.add_argument("--allow-missing", action="store_true", help="exit 0 even when a world has no reference")
    args = ap.parse_args(argv)
    rows = []
    print(f"{'world':<28} {'bodies':>6} {'manifolds':>9} {'seconds':>8} {'residual':>9}  method (friction phase)",
          flush=True)
    for scene, scene_args in worlds(args.scenes, args.seeds):
        row = survey_world(scene, scene_args, args.budget)
        rows.append(row)
        residual = "-" if row.residual is None else f"{row.residual:.1e}"
        tail = row.method if not row.reason else f"no exact reference ({row.reason})"
        print(f"{row.world:<28} {row.bodies:>6} {row.manifolds:>9} {row.seconds:>8.2f} {residual:>9}  {tail}",
              flush=True)
    found = [r for r in rows if r.residual is not None]
    worst = max((r.residual for r in found), default=0.0)
    slowest = max((r.seconds for r in rows), default=0.0)
    print(f"{len(found)} of {len(rows)} worlds have an exact reference; largest residual {worst:.1e}; slowest "
          f"{slowest:.1f} s")
    return 0 if len(found) == len(rows) or args.allow_missing else 1


if __name__ == "__main__":
    raise SystemExit(main())
