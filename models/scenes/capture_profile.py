"""Where a contact capture's time goes, on a thesis-like scene (default a fraction of the thesis's cubes):
``python -m models.scenes.capture_profile --nx 12 --ny 30 --nz 12``.

Builds the scene, runs its steps, then reads the manifolds four ways in the same world: a query of every body
(the old capture), a query of a vertex cover of the broadphase, the cover read by forked readers, and by one
consuming reader; prints the seconds of each, the queries, the manifold count M and the cost of one query, and
checks that all agree byte for byte. Extrapolation to the thesis frame: a query costs about (M / measured M) times
the measured query (the server scans every manifold per query), times the number of queries."""

from __future__ import annotations

import argparse
import time
from typing import Sequence

import numpy as np

from models.scenes.contact_capture import query_plan, read_manifolds
from models.scenes.specs import DEFAULT_CAPTURE_STEP
from models.scenes.specs import THESIS_FRAME_BODIES as THESIS_BODIES
from models.scenes.specs import THESIS_FRAME_MANIFOLDS as THESIS_MANIFOLDS
from models.scenes.world import build_world


def _same(a: object, b: object) -> bool:
    return all(getattr(a, k).tobytes() == getattr(b, k).tobytes() for k in a.__dataclass_fields__)  # type: ignore


def profile(nx: int, ny: int, nz: int, workers: int) -> dict[str, float]:
    out: dict[str, float] = {}
    t0 = time.perf_counter()
    with build_world("thesis", nx=nx, ny=ny, nz=nz) as w:
        out["build_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        for _ in range(DEFAULT_CAPTURE_STEP["thesis"]):
            w.step()
        out["steps_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        full = read_manifolds(w.client, w.bodies, np.arange(w.num_bodies), 1)
        out["full_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        plan = query_plan(w.client, w.bodies, w.dynamic, w._plan_margin())
        out["plan_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        cover = read_manifolds(w.client, w.bodies, plan, 1)
        out["cover_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        forked = read_manifolds(w.client, w.bodies, plan, workers, parallel_min=1)
        out["cover_forked_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        consumed = read_manifolds(w.client, w.bodies, plan, 1, parallel_min=1, consume=True)
        out["cover_consumed_s"] = time.perf_counter() - t0
        out.update(bodies=w.num_bodies, queries=len(plan), manifolds=len(full), workers=workers,
                   identical=float(_same(full, cover) and _same(full, forked) and _same(full, consumed)))
    out["query_us"] = out["full_s"] / out["bodies"] * 1e6
    per_thesis_query = out["query_us"] * THESIS_MANIFOLDS / out["manifolds"] * 1e-6
    out["thesis_full_s_est"] = per_thesis_query * THESIS_BODIES
    out["thesis_cover_s_est"] = per_thesis_query * THESIS_BODIES * out["queries"] / out["bodies"]
    return out


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m models.scenes.capture_profile", description=__doc__)
    ap.add_argument("--nx", type=int, default=12)
    ap.add_argument("--ny", type=int, default=30)
    ap.add_argument("--nz", type=int, default=12)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args(argv)
    r = profile(args.nx, args.ny, args.nz, args.workers)
    for k, v in r.items():
        print(f"{k}: {v:.3f}" if isinstance(v, float) and not float(v).is_integer() else f"{k}: {int(v)}")
    return 0 if r["identical"] else 1


if __name__ == "__main__":
    raise SystemExit(main())
