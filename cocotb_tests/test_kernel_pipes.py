"""Bit-exact tests of the generated kernel datapaths (rtl/generated/pgs_{contact,friction,integrate}_pipe.sv and the
shared datapath of a lane, pgs_shared_pipe.sv).

For each module and each format (fp32, fp16, bf16) the module is compiled once with Verilator into a
C++ executable (``cocotb_tests/pipes/pipe_main.cpp``: one input record per cycle, 25 % random idle
cycles with junk inputs (the operators and delay lines take a word only with its valid bit, so idle cycles
between records are what checks those enables), checks of LATENCY, order, tag pass-through and reset). Every output word
must equal, bit for bit, the golden model (``contact_solve`` / ``friction_solve`` / ``integrate``
through ``models/kernel/kernel_vectors.py``) evaluated on the same input words.

Inputs: the real inputs of every manifold-pass (and of the integration of every dynamic body) of a
4-iteration golden solve of the pile (4x3x4), stack and incline scenes, in the format, plus seeded
perturbations of them: scaled and noisy velocities and impulses, unused (zero-jac) points, skipped
friction rows (f_jac_inv[0] = 0), spin damping on and off, static bodies, large angular velocities
(angle clamp) and tiny ones (small-angle branch). ``SEED=<int>`` overrides the base seed.

The shared datapath (rtl/gen/shared_datapath.py) takes the contact and the friction vectors in one random order (so
the kind changes from one record to the next at random), each in its kind's words of the shared layout with random
bits in the words its kind does not read, and must give every output of the kind (out_kind too) as that kind's
golden model does.

Floating-point events: each vector is taken with ``in_count`` set or (about one in six, at random) clear;
the module's ``ev_overflow`` / ``ev_underflow`` / ``ev_invalid`` outputs summed over the run must equal the
graph's software twin with a counting format (``Graph.count_events``) over the counted vectors. In fp16 every
pipe flushes results to zero and the integration also overflows (large angular velocities squared) and
computes 0/0 (sin(x)/theta at theta = 0, discarded by the small-angle select); in fp32 and bf16 only that 0/0.

Also: the generated files are up to date with ``python -m rtl.gen``, rtl/pgs_kernel.f lists every RTL source,
the injected-bug friction pipe is generated apart and is wrong, and the graphs' software twin (``Graph.evaluate``)
matches the golden model.
"""

from __future__ import annotations

import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from models.kernel import kernel_vectors as kv  # noqa: E402
from models import scenes  # noqa: E402
from models.setup.constraints import body_table, setup_constraints  # noqa: E402
from models.golden.contact_solver import FRICTION_COEFF  # noqa: E402
from models.golden.integrator import MAX_ANGLE  # noqa: E402
from models.formats.number_format import EVENT_NAMES, KERNEL_FORMATS, FpEvents, NumberFormat  # noqa: E402
from models.kernel.kernel_job import KernelJob  # noqa: E402
from models.scenes.kernel_scenes import PIPE_VECTOR_SCENES  # noqa: E402
from rtl.gen import friction_sign_bug_sources, generate, generate_friction_sign_bug, render  # noqa: E402
from rtl.gen.file_list import FileListError, kernel_sources, read_file_list, swap_sources  # noqa: E402
from rtl.gen.kernel_graphs import (CONTACT_IN, CONTACT_OUT, FRICTION_IN, FRICTION_OUT, GRAPHS, INTEGRATE_IN,
                                   INTEGRATE_OUT, MAN_BITS_OF, SHARED_GRAPHS, SHARED_OUT, contact_graph,
                                   friction_graph, shared_graph, shared_in)  # noqa: E402
from rtl.gen.file_list import rtl_files  # noqa: E402
from sim.compile.verilator_build import DEBUG_COMPILE_ARGS, build  # noqa: E402
from sim.drive.seed import run_seed  # noqa: E402
from rtl.gen.operator_schedule import schedule  # noqa: E402

HERE = Path(__file__).resolve().parent / "pipes"
RTL = REPO / "rtl"
IDLE_PERMILLE = 250  # idle cycles between the records, per mille
FORMATS = KERNEL_FORMATS
# Verilator: keep every operator instance a separate function (-fno-inline) and compile without C++
# optimization: the designs are large and the runs short, so this is the fastest overall.
BUILD_ARGS = DEBUG_COMPILE_ARGS


@dataclass(frozen=True)
class PipeSpec:
    module: str
    in_names: list[str]
    out_names: list[str]
    spin: bool
    kind: bool = False  # a shared datapath: in_kind / out_kind


SHARED_IN, SHARED_C_SLOT, SHARED_F_SLOT = shared_in()
PIPES = {
    "contact": PipeSpec("pgs_contact_pipe", CONTACT_IN, CONTACT_OUT, False),
    "friction": PipeSpec("pgs_friction_pipe", FRICTION_IN, FRICTION_OUT, True),
    "integrate": PipeSpec("pgs_integrate_pipe", INTEGRATE_IN, INTEGRATE_OUT, False),
    "shared": PipeSpec("pgs_shared_pipe", SHARED_IN, SHARED_OUT, True, kind=True),
}
SPIN_BIT, COUNT_BIT, KIND_BIT = 0, 1, 2  # the flags word of pipe_main.cpp
FRICTION_IMPULSE_WORDS = [0, 1, None, None]  # the shared datapath's imp0..3 of a friction record: lamT0, lamT1, 0, 0


def seed_for(fmt_name: str, pipe: str) -> int:
    base = run_seed()
    return base + 10 * list(FORMATS).index(fmt_name) + list(PIPES).index(pipe)


# ------------------------------------------------------------------------------------------------
# Vectors
# ------------------------------------------------------------------------------------------------
_FRAMES: dict[str, tuple] = {}
_SCENE_VECTORS: dict[str, list[kv.SceneVectors]] = {}


def scene_data(fmt: NumberFormat) -> list[kv.SceneVectors]:
    if fmt.name in _SCENE_VECTORS:
        return _SCENE_VECTORS[fmt.name]
    out = []
    for name, params in PIPE_VECTOR_SCENES.items():
        if name not in _FRAMES:
            frame = scenes.load_or_capture(name, **params)
            bodies = body_table(frame)
            _FRAMES[name] = (frame, bodies, setup_constraints(frame, bodies))
        frame, bodies, cons = _FRAMES[name]
        out.append(kv.scene_vectors(bodies.rounded(fmt), cons.rounded(fmt), fmt, dt=frame.dt,
                                    gravity=tuple(frame.gravity)))
    _SCENE_VECTORS[fmt.name] = out
    return out


def _log_uniform(rng: np.random.Generator, lo: float, hi: float, shape) -> np.ndarray:
    return np.exp(rng.uniform(np.log(lo), np.log(hi), shape))


def _scale_rows(rng: np.random.Generator, w: np.ndarray, cols: slice, lo: float, hi: float) -> None:
    """Scale the vector in ``cols`` of each row by a random factor and add relative noise."""
    k = w.shape[0]
    f = _log_uniform(rng, lo, hi, (k, 1)) * rng.choice([-1.0, 1.0], (k, 1), p=[0.2, 0.8])
    w[:, cols] = w[:, cols] * f + rng.normal(0, 0.05, (k, cols.stop - cols.start)) * np.abs(w[:, cols]).max(
        axis=1, keepdims=True)


def _make_static(rng: np.random.Generator, w: np.ndarray, inv_mass_col: int, inv_inertia: slice,
                 share: float) -> None:
    """Make one body of a random ``share`` of the rows static: its inverse mass and inverse inertia 0."""
    static = rng.random(w.shape[0]) < share
    w[static, inv_mass_col] = 0.0
    w[static, inv_inertia] = 0.0


def contact_vectors(fmt: NumberFormat, sv: list[kv.SceneVectors], rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    base = np.concatenate([s.contact for s in sv])
    sets = {"scene": base}
    p = base[rng.integers(0, len(base), 2500)].copy()
    k = len(p)
    for c0 in (33, 36, 39, 42):                                  # vA, wA, vB, wB
        _scale_rows(rng, p, slice(c0, c0 + 3), 0.01, 30.0)
    p[:, 23:27] *= _log_uniform(rng, 0.01, 100.0, (k, 4)) * (rng.random((k, 4)) < 0.8)   # lam (some 0)
    p[:, 19:23] += rng.normal(0, 0.5, (k, 4)) * (p[:, 15:19] != 0)                     # bias
    unused = rng.random((k, 4)) < 0.25                                                  # zero-jac points
    p[:, 15:19] = np.where(unused, 0.0, p[:, 15:19])
    p[rng.random(k) < 0.05, 15:19] = 0.0                                                # all points unused
    _make_static(rng, p, 46, slice(50, 53), 0.2)  # body B static
    _make_static(rng, p, 45, slice(47, 50), 0.05)  # body A static
    sets["perturbed"] = p
    return np.concatenate(list(sets.values())), {n: len(v) for n, v in sets.items()}


def friction_vectors(fmt: NumberFormat, sv: list[kv.SceneVectors],
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, dict]:
    base = np.concatenate([s.friction for s in sv])
    spin = np.concatenate([s.spin_damp for s in sv])
    sets = {"scene": (base, spin)}
    sel = rng.integers(0, len(base), 2500)
    p, ps = base[sel].copy(), spin[sel].copy()
    k = len(p)
    for c0 in (26, 29, 32, 35):                                  # vA, wA, vB, wB
        _scale_rows(rng, p, slice(c0, c0 + 3), 0.01, 30.0)
    p[:, 14:18] *= _log_uniform(rng, 0.01, 100.0, (k, 4)) * (rng.random((k, 4)) < 0.9)  # lam_n
    limit = FRICTION_COEFF * p[:, 14:18].sum(axis=1, keepdims=True)
    p[:, 18:20] = rng.uniform(-1.5, 1.5, (k, 2)) * limit * (rng.random((k, 2)) < 0.8)     # lamT
    ps = np.where(rng.random(k) < 0.5, ~ps, ps)                                          # spin on / off
    p[rng.random(k) < 0.1, 12] = 0.0                                                     # skipped rows
    _make_static(rng, p, 39, slice(43, 46), 0.2)  # body B static
    _make_static(rng, p, 38, slice(40, 43), 0.05)  # body A static
    sets["perturbed"] = (p, ps)
    words = np.concatenate([v[0] for v in sets.values()])
    flags = np.concatenate([v[1] for v in sets.values()])
    return words, flags, {n: len(v[0]) for n, v in sets.items()}


def integrate_vectors(fmt: NumberFormat, sv: list[kv.SceneVectors], rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    base = np.concatenate([s.integrate for s in sv])
    sets = {"scene": base}
    n = 2500
    w = np.empty((n, 18))
    w[:, 0:3] = rng.uniform(-50, 50, (n, 3))
    q = rng.normal(size=(n, 4))
    w[:, 3:7] = q / np.linalg.norm(q, axis=1, keepdims=True)
    w[:, 7:10] = rng.normal(0, 5, (n, 3))
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    dt = rng.choice([1 / 60, 1 / 120, 1 / 240, 1 / 30], n)
    kind = rng.integers(0, 5, n)
    mag = np.select([kind == 0, kind == 1, kind == 2, kind == 3],
                    [_log_uniform(rng, 1e-6, 1e-3, n),                    # small-angle branch
                     _log_uniform(rng, 1e-3, 40.0, n),                    # ordinary
                     _log_uniform(rng, 40.0, 400.0, n),                   # angle clamp
                     (MAX_ANGLE / dt) * rng.uniform(0.999, 1.011, n)],   # around the clamp
                    np.zeros(n))                                          # zero
    w[:, 10:13] = dirs * mag[:, None]
    w[:, 13] = dt
    w[:, 14] = rng.choice([0.99, 1.0, 0.95], n, p=[0.8, 0.1, 0.1])
    gravities = np.array([[0.0, -9.8, 0.0], [0.0, 0.0, -9.81], [1.5, -9.7, 0.3], [0.0, 0.0, 0.0]])
    w[:, 15:18] = gravities[rng.choice(len(gravities), n, p=[0.7, 0.1, 0.1, 0.1])]
    sets["random"] = w
    return np.concatenate(list(sets.values())), {n_: len(v) for n_, v in sets.items()}


def shared_vectors(fmt: NumberFormat, sv: list[kv.SceneVectors], rng: np.random.Generator) -> tuple[np.ndarray,
                                                                                                    np.ndarray, dict]:
    """The contact and friction vectors in one random order, in the shared layout (a kind's words at its slots, random
    bit patterns elsewhere); flags: bit 0 spin damping, bit 2 the kind."""
    c_words, c_counts = contact_vectors(fmt, sv, rng)
    f_words, f_spin, f_counts = friction_vectors(fmt, sv, rng)
    with np.errstate(all="ignore"):
        c_bits, f_bits = fmt.encode(c_words).astype(np.uint32), fmt.encode(f_words).astype(np.uint32)
    n_c, n_f = len(c_bits), len(f_bits)
    bits = rng.integers(0, 1 << fmt.width, (n_c + n_f, len(SHARED_IN)), dtype=np.uint32)
    bits[np.ix_(np.arange(n_c), SHARED_C_SLOT)] = c_bits
    bits[np.ix_(np.arange(n_c, n_c + n_f), SHARED_F_SLOT)] = f_bits
    flags = np.concatenate([np.zeros(n_c, np.uint32), f_spin.astype(np.uint32) | (1 << KIND_BIT)])
    order = rng.permutation(n_c + n_f)
    counts = {f"contact {k}": v for k, v in c_counts.items()} | {f"friction {k}": v for k, v in f_counts.items()}
    return bits[order], flags[order], counts


def kinds_of(flags: np.ndarray) -> np.ndarray:
    """The friction records of a shared datapath's vectors."""
    return (np.asarray(flags, np.uint32) >> KIND_BIT & 1).astype(bool)


def make_vectors(pipe: str, fmt: NumberFormat, seed: int) -> tuple[np.ndarray, np.ndarray, dict]:
    """(input bit patterns (K, N_IN), flags (K,): spin damping (and the shared datapath's kind bit), set sizes). The
    event-count flags are drawn separately (:func:`count_flags`) so that these vectors stay those of earlier runs."""
    rng = np.random.default_rng(seed)
    sv = scene_data(fmt)
    if pipe == "shared":
        return shared_vectors(fmt, sv, rng)
    if pipe == "contact":
        words, counts = contact_vectors(fmt, sv, rng)
        flags = np.zeros(len(words), dtype=bool)
    elif pipe == "friction":
        words, flags, counts = friction_vectors(fmt, sv, rng)
    else:
        words, counts = integrate_vectors(fmt, sv, rng)
        flags = np.zeros(len(words), dtype=bool)
    with np.errstate(all="ignore"):
        bits = fmt.encode(words).astype(np.uint32)
    return bits, flags.astype(bool), counts


def count_flags(n: int, seed: int) -> np.ndarray:
    """Which vectors are taken with in_count (about 5 in 6)."""
    return np.random.default_rng(seed + 7).random(n) >= 1 / 6


def shared_golden_bits(fmt: NumberFormat, bits: np.ndarray, flags: np.ndarray) -> np.ndarray:
    """The shared datapath's outputs: each record's kind's golden model, in the shared output words."""
    fric = kinds_of(flags)
    out = np.zeros((len(bits), len(SHARED_OUT)), np.uint32)
    out[~fric] = golden_bits("contact", fmt, bits[~fric][:, SHARED_C_SLOT], np.zeros(int((~fric).sum()), bool))
    f_out = golden_bits("friction", fmt, bits[fric][:, SHARED_F_SLOT], (flags[fric] >> SPIN_BIT & 1).astype(bool))
    for k, j in enumerate(FRICTION_IMPULSE_WORDS + list(range(2, len(FRICTION_OUT)))):
        out[fric, k] = 0 if j is None else f_out[:, j]
    return out


def shared_events(fmt: NumberFormat, bits: np.ndarray, flags: np.ndarray):  # noqa: ANN201
    """The events of the two graphs' twins over their kinds' (counted) vectors, summed."""
    fric = kinds_of(flags)
    x = fmt.decode(bits.astype(np.uint64))
    ev = contact_graph().count_events(fmt, x[~fric][:, SHARED_C_SLOT])
    ev.add(friction_graph().count_events(fmt, x[fric][:, SHARED_F_SLOT], (flags[fric] >> SPIN_BIT & 1).astype(bool)[:, None]))
    return ev


def golden_bits(pipe: str, fmt: NumberFormat, bits: np.ndarray, flags: np.ndarray) -> np.ndarray:
    if pipe == "shared":
        return shared_golden_bits(fmt, bits, flags)
    x = fmt.decode(bits.astype(np.uint64))
    with np.errstate(all="ignore"):
        if pipe == "contact":
            y = kv.contact_golden(fmt, x)
        elif pipe == "friction":
            y = kv.friction_golden(fmt, x, flags)
        else:
            y = kv.integrate_golden(fmt, x)
        return fmt.encode(y).astype(np.uint32)


# ------------------------------------------------------------------------------------------------
# Harness
# ------------------------------------------------------------------------------------------------
@dataclass
class Harness:
    pipe: str
    fmt_name: str
    exe: Path
    latency: int
    build_s: float


PARAMS = [(p, f) for f in FORMATS for p in PIPES]


def build_harness(pipe: str, fmt_name: str, sources: list[Path], name: str) -> Harness:
    """The compiled pipe_main.cpp driver of one pipe module (``sources``: its files, top last) in one format."""
    spec = PIPES[pipe]
    fmt = FORMATS[fmt_name]
    t0 = time.monotonic()
    exe = build(
        sources=sources,
        top=spec.module,
        parameters={"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits},
        cpp_files=[HERE / "pipe_main.cpp"],
        name=name,
        cflags=[f"-DPIPE_CLASS=V{spec.module}", f"-DN_IN={len(spec.in_names)}", f"-DN_OUT={len(spec.out_names)}",
                f"-DFMT_W={fmt.width}", f"-DHAS_SPIN_DAMP={int(spec.spin)}", f"-DHAS_KIND={int(spec.kind)}"],
        extra_args=BUILD_ARGS,
    )
    latency = (SHARED_GRAPHS[spec.module]().latency_for(MAN_BITS_OF[fmt_name]) if spec.kind
               else schedule(GRAPHS[spec.module]()).latency_for(MAN_BITS_OF[fmt_name]))
    return Harness(pipe, fmt_name, exe, latency, time.monotonic() - t0)


@pytest.fixture(scope="module", params=PARAMS, ids=[f"{p}-{f}" for p, f in PARAMS])
def harness(request: pytest.FixtureRequest) -> Harness:
    pipe, fmt_name = request.param
    module = PIPES[pipe].module
    return build_harness(pipe, fmt_name, [RTL / "pgs_fp_pkg.sv", RTL / "pgs_delay.sv"]
                         + sorted((RTL / "fp").glob("*.sv")) + [RTL / "generated" / f"{module}.sv"],
                         f"{module}_{fmt_name}")


def run_harness(h: Harness, bits: np.ndarray, flags: np.ndarray, count: np.ndarray, tmp: Path,
                seed: int) -> tuple[np.ndarray, str]:
    spec = PIPES[h.pipe]
    word = flags.astype(np.uint32) | (count.astype(np.uint32) << np.uint32(COUNT_BIT))
    rec = np.concatenate([bits, word[:, None]], axis=1).astype("<u4")
    inp, outp = tmp / "in.bin", tmp / "out.bin"
    rec.tofile(inp)
    proc = subprocess.run([str(h.exe), str(inp), str(outp), str(h.latency), str(seed), str(IDLE_PERMILLE)],
                          capture_output=True, text=True)
    assert proc.returncode == 0, f"harness failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    res = np.fromfile(outp, dtype="<u4")
    assert res.size == len(bits) * len(spec.out_names), f"{res.size} output words for {len(bits)} vectors"
    return res.reshape(len(bits), len(spec.out_names)), proc.stdout


def test_kernel_pipe_bit_exact(harness: Harness, tmp_path: Path) -> None:
    check_pipe_bit_exact(harness, tmp_path)


def check_pipe_bit_exact(harness: Harness, tmp_path: Path) -> None:
    """Run the pipe's vectors through its harness: every output word equals the golden model's, bit for bit, the
    LATENCY and order hold, and the event counts equal the graph twin's over the counted vectors."""
    fmt = FORMATS[harness.fmt_name]
    spec = PIPES[harness.pipe]
    seed = seed_for(harness.fmt_name, harness.pipe)
    t0 = time.monotonic()
    bits, flags, counts = make_vectors(harness.pipe, fmt, seed)
    count = count_flags(len(bits), seed)
    t1 = time.monotonic()
    res, log = run_harness(harness, bits, flags, count, tmp_path, seed)
    t2 = time.monotonic()
    exp = golden_bits(harness.pipe, fmt, bits, flags)
    x = fmt.decode(bits[count].astype(np.uint64))
    with np.errstate(all="ignore"):
        ev = (shared_events(fmt, bits[count], flags[count]) if spec.kind else
              GRAPHS[spec.module]().count_events(fmt, x, flags[count][:, None] if spec.spin else None))
    t3 = time.monotonic()
    print(f"\n[{spec.module} {harness.fmt_name}] LATENCY {harness.latency}; SEED={seed}; build {harness.build_s:.1f} s; "
          f"vectors {len(bits)} {counts}; gen {t1 - t0:.1f} s, sim {t2 - t1:.1f} s, golden {t3 - t2:.1f} s\n"
          f"  {log.strip()}")

    # Not vacuous: one output record per vector.
    assert res.shape == exp.shape == (len(bits), len(spec.out_names))
    assert f"vectors={len(bits)} outputs={len(bits)} " in log
    assert f"latency={harness.latency}" in log
    got_ev = dict(zip(EVENT_NAMES, (int(v) for v in log.split("events=")[1].split()[0].split(","))))
    print(f"  events over {int(count.sum())} counted vectors: kernel {got_ev}, twin {ev.as_dict()}")
    assert got_ev == ev.as_dict(), f"[{spec.module} {harness.fmt_name}] event counts differ from the twin"
    if harness.fmt_name == "fp16":  # not vacuous: fp16 flushes in every pipe; the integration raises all three
        assert ev.underflow > 0 and (harness.pipe != "integrate" or min(ev.as_dict().values()) > 0), ev
    if spec.kind:  # not vacuous: both kinds, and the kind changes between records more often than not
        fric = kinds_of(flags)
        assert 0.3 < fric.mean() < 0.7 and (fric[1:] != fric[:-1]).mean() > 0.4

    bad = np.argwhere(res != exp)
    if len(bad):
        w = (fmt.width + 3) // 4
        lines = []
        for i, k in bad[:12]:
            got = fmt.decode(np.uint64(res[i, k]))
            want = fmt.decode(np.uint64(exp[i, k]))
            lines.append(f"  {spec.module} vector {i} word {k} ({spec.out_names[k]}): got 0x{res[i, k]:0{w}x} ({got!r}) "
                         f"expected 0x{exp[i, k]:0{w}x} ({want!r})")
        rows = sorted({int(i) for i, _ in bad})
        pytest.fail(f"[{spec.module} {harness.fmt_name}] {len(bad)} word mismatches in {len(rows)} of {len(bits)} "
                    f"vectors (seed {seed}):\n" + "\n".join(lines))


def test_generated_rtl_up_to_date() -> None:
    """Every generated copy (the datapaths, those of the other inverse-inertia modes, the shared datapaths, the latency
    package and JSON,
    the register and stream layout packages and the HLS headers of the register map and the stream layout) equals
    what the generator writes now."""
    rendered = {p.relative_to(REPO).as_posix() for p in render()}
    assert rendered == {"rtl/generated/pgs_contact_pipe.sv", "rtl/generated/pgs_friction_pipe.sv",
                        "rtl/generated/pgs_contact_pipe_scalar.sv", "rtl/generated/pgs_friction_pipe_scalar.sv",
                        "rtl/generated/pgs_contact_pipe_full.sv", "rtl/generated/pgs_friction_pipe_full.sv",
                        "rtl/generated/pgs_contact_pipe_soft.sv",
                        "rtl/generated/pgs_friction_pipe_mu.sv", "rtl/generated/pgs_friction_pipe_scalar_mu.sv",
                        "rtl/generated/pgs_friction_pipe_full_mu.sv", "rtl/generated/pgs_integrate_pipe.sv", "rtl/generated/pgs_pipe_latency_pkg.sv",
                        "rtl/generated/pgs_friction_pipe_tb.sv",
                        *(f"rtl/generated/{name}.sv" for name in SHARED_GRAPHS),
                        "rtl/generated/pipe_latency.json", "rtl/generated/pgs_regs_pkg.sv",
                        "rtl/generated/pgs_stream_layout_pkg.sv",
                        "hls_export/generated/pgs_regs.h", "hls_export/generated/pgs_stream_layout.h",
                        "hls_export/generated/pgs_shared_datapath.h"}
    stale = generate(check=True)
    assert not stale, f"regenerate with `python -m rtl.gen`: {[str(p) for p in stale]}"
    written = {p.relative_to(REPO).as_posix() for p in (RTL / "generated").iterdir()}
    written.discard("rtl/generated/xls")  # the XLS datapath's folder (rtl/gen/xls_flow.py; test_xls_datapath.py)
    assert written <= rendered, f"files in rtl/generated/ the generator does not write: {sorted(written - rendered)}"
    for path in render():  # the first line says the file is generated (JSON: its "about" key)
        head = path.read_text().splitlines()[0 if path.suffix != ".json" else 1]
        assert "generated by rtl/gen (python -m rtl.gen), do not edit" in head, path


def test_kernel_file_list_names_every_rtl_source() -> None:
    """rtl/pgs_kernel.f lists every SystemVerilog file under rtl/ once (but the XLS datapath's, which
    rtl.gen.xls_flow.xls_sources swaps in), packages first, pgs_kernel last; no file of the product RTL has a
    test-only parameter."""
    sources = kernel_sources()
    xls = set((RTL / "generated" / "xls").resolve().glob("*.sv"))
    assert set(sources) == set(RTL.resolve().rglob("*.sv")) - xls, "a file under rtl/ is missing from rtl/pgs_kernel.f"
    packages, modules = rtl_files()
    assert sources[:len(packages)] == packages and sources[-1].name == "pgs_kernel.sv"
    assert [p.name for p in packages] == ["pgs_fp_pkg.sv", "pgs_regs_pkg.sv", "pgs_stream_layout_pkg.sv",
                                           "pgs_pipe_latency_pkg.sv", "pgs_seq_pkg.sv"]
    assert not [p.name for p in sources if "TEST_" in p.read_text()]


def test_file_list_errors(tmp_path: Path) -> None:
    (tmp_path / "a.sv").write_text("module a; endmodule\n")
    bad = {"missing.sv": "does not exist", "a.sv\na.sv": "listed twice", "-y .": "not a single source path",
           "// only a comment": "lists no source"}
    for text, message in bad.items():
        f = tmp_path / "list.f"
        f.write_text(text + "\n")
        with pytest.raises(FileListError, match=message):
            read_file_list(f)
    f.write_text("// the one file\na.sv  // trailing comment\n")
    assert read_file_list(f) == [(tmp_path / "a.sv").resolve()]
    with pytest.raises(FileListError, match="no source to replace"):
        swap_sources(read_file_list(f), [tmp_path / "b.sv"])


def test_friction_sign_bug_variant(tmp_path: Path) -> None:
    """The injected-bug friction pipe and shared datapath: written only where asked (never into rtl/), the product
    modules' names and ports, no parameter; swapped into the kernel's source list in place of the product modules; and
    wrong: the friction pipe's software twin differs from the golden model on the scene vectors, in the velocity words
    only, and so does the shared datapath's for its friction records only."""
    paths = generate_friction_sign_bug(tmp_path / "bug")
    assert [p.name for p in paths] == ["pgs_friction_pipe.sv", "pgs_shared_pipe.sv"]
    for path in paths:
        product = (RTL / "generated" / path.name).read_text()
        text = path.read_text()
        assert text != product and "INJECTED BUG" in text
        assert "TEST_" not in text and f"module {path.stem} #(" in text
        ports = [line for line in text.splitlines() if line.startswith("    input ") or line.startswith("    output ")]
        assert ports == [line for line in product.splitlines()
                         if line.startswith("    input ") or line.startswith("    output ")]
    sources = friction_sign_bug_sources(tmp_path / "bug")
    assert len(sources) == len(kernel_sources())
    for path in paths:
        assert [s for s in sources if s.name == path.name] == [path.resolve()]
    with pytest.raises(ValueError, match="build directory"):
        generate_friction_sign_bug(RTL / "generated")
    fmt = FORMATS["fp32"]
    bits, flags, _ = make_vectors("shared", fmt, seed_for("fp32", "shared"))
    fric = kinds_of(flags)
    dp = shared_graph(sign_bug=True)
    x = fmt.decode(bits.astype(np.uint64))
    with np.errstate(all="ignore"):
        c_twin = fmt.encode(dp.evaluate(fmt, 0, x[~fric])).astype(np.uint32)
        f_twin = fmt.encode(dp.evaluate(fmt, 1, x[fric], {"in_spin_damp": (flags[fric] & 1).astype(bool)}))
    exp = golden_bits("shared", fmt, bits, flags)
    assert np.array_equal(c_twin, exp[~fric]), "the injected friction bug changes a contact record"
    assert (f_twin != exp[fric]).any(axis=0)[4:].any(), "the injected bug changes no velocity of the shared datapath"
    bits, flags, _ = make_vectors("friction", fmt, seed_for("fp32", "friction"))
    x = fmt.decode(bits.astype(np.uint64))
    with np.errstate(all="ignore"):
        twin = fmt.encode(friction_graph(sign_bug=True).evaluate(fmt, x, flags[:, None])).astype(np.uint32)
    differs = (twin != golden_bits("friction", fmt, bits, flags)).any(axis=0)
    assert differs[2:].any(), "the injected bug changes no velocity"


def shared_twin(module: str, fmt: NumberFormat, bits: np.ndarray, flags: np.ndarray) -> np.ndarray:
    """A shared datapath's outputs computed over its binding (``SharedDatapath.evaluate``), each record by its kind."""
    dp = SHARED_GRAPHS[module]()
    x = fmt.decode(bits.astype(np.uint64))
    fric = kinds_of(flags)
    out = np.zeros((len(bits), len(SHARED_OUT)))
    with np.errstate(all="ignore"):
        out[~fric] = dp.evaluate(fmt, 0, x[~fric])
        out[fric] = dp.evaluate(fmt, 1, x[fric], {"in_spin_damp": (flags[fric] >> SPIN_BIT & 1).astype(bool)})
        return fmt.encode(out).astype(np.uint32)


@pytest.mark.parametrize("fmt_name", list(FORMATS))
def test_graph_twin_matches_golden(fmt_name: str) -> None:
    """The graphs interpreted in Python, and the shared datapath computed over its binding, equal the golden model on
    the scene inputs (no RTL needed)."""
    fmt = FORMATS[fmt_name]
    for pipe, spec in PIPES.items():
        bits, flags, _ = make_vectors(pipe, fmt, seed_for(fmt_name, pipe))
        x = fmt.decode(bits.astype(np.uint64))
        with np.errstate(all="ignore"):
            twin = (shared_twin(spec.module, fmt, bits, flags) if spec.kind else
                    fmt.encode(GRAPHS[spec.module]().evaluate(fmt, x, flags[:, None])).astype(np.uint32))
        exp = golden_bits(pipe, fmt, bits, flags)
        bad = np.argwhere(twin != exp)
        assert not len(bad), f"{spec.module} {fmt_name}: graph twin differs at {bad[:8].tolist()}"


def _graph_events(job: KernelJob) -> FpEvents:
    """The events of the datapath graphs (the generated pipes' software twin) on the inputs every issued
    manifold-pass and dynamic body sees in the golden step: the RTL's operators, counted."""
    from rtl.gen.kernel_graphs import contact_graph

    ip, words = job.iparams, job.inertia_words
    sv = kv.scene_vectors(job.bodies, job.cons, job.fmt, job.params, dt=ip.dt, gravity=ip.gravity,
                          damping=ip.damping, schedule=job.schedule, inertia_words=words, initial=job.initial,
                          record_checks=job.record_checks())
    friction = friction_graph(inertia_words=words, manifold_friction=job.friction_words == 1,
                              tangents_on_chip=job.tangents_on_chip)
    fw = sv.friction
    if job.tangents_on_chip:  # the record carries no tangents: the pipe derives them from n
        keep = [k for k, name in enumerate(FRICTION_IN) if not name.startswith(("t0_", "t1_"))]
        fw = fw[:, keep]
    total = FpEvents()
    with np.errstate(all="ignore"):
        for graph, x, flags in ((contact_graph(words), sv.contact, None), (friction, fw, sv.spin_damp[:, None]),
                                (GRAPHS["pgs_integrate_pipe"](), sv.integrate, None)):
            total.add(graph.count_events(job.fmt, x, flags))
    return total


EVENT_JOBS = ["fp32", "fp16", "bf16", "fp16-tangents", "fp32-extremes", "fp16-extremes", "fp32-extremes-window-l2",
              "fp32-extremes-records-window", "fp16-extremes-records-window-l2-interleaved", "fp32-extremes-tangents"]


@pytest.mark.parametrize("name", EVENT_JOBS)
def test_golden_event_count_equals_the_datapaths(name: str) -> None:
    """The golden model's count of its own floating-point events (``sim.drive.kernel_step.golden_step``: its
    arithmetic counting every operation) equals the datapath graphs' count of their operators' events on the same
    step, operation for operation: the golden model computes every point, every manifold's spin damping and every
    body's run constants as the pipes do, and the tangents the kernel derives in every friction manifold-pass are
    counted per pass. The kernel's counters are compared with the golden model's count in every kernel run
    (``sim.drive.kernel_step.check_counters``); this holds the two counts equal without RTL, also at the extremes
    (``models.kernel.extreme_stimulus``, seed ``SEED``) where each counter reaches the thousands."""
    from models.golden.contact_solver import SolverParams
    from models.kernel.extreme_stimulus import extreme_magnitudes
    from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
    from sim.drive.cocotb_run import test_seed
    from sim.drive.kernel_step import golden_step

    fmt = KERNEL_FORMATS[name.split("-")[0]]
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    window = "window" in name
    job = KernelJob.from_frame(frame, fmt, SolverParams(4, interleaved="interleaved" in name),
                               "sweep" if window else "hazard")
    job = job.impulses_travelling() if "records" in name else job
    job = job.windowed(1024, lanes=2 if "l2" in name else 1) if window else job
    job = extreme_magnitudes(job, test_seed()) if "extremes" in name else job
    job = job.tangents_derived() if "tangents" in name else job
    golden, graphs = golden_step(job).events.as_dict(), _graph_events(job).as_dict()
    print(name, "golden model", golden, "datapaths", graphs)
    assert golden == graphs
    if "extremes" in name:
        assert min(golden.values()) >= 50, golden
    elif fmt.name == "fp16":
        assert golden["underflow"] > 0, golden  # fp16 flushes tiny velocity terms of the resting pile
    else:
        assert golden == dict.fromkeys(EVENT_NAMES, 0), golden
