"""Bullet's batched GPU PGS scheme written in NVIDIA Warp: a peer a user could run instead of the FPGA kernel.

The step is the one Bullet3's OpenCL pipeline runs with ``gUseLargeBatches`` (one batching of the whole frame, one
launch per batch), in float32:

* the frame's manifolds in Bullet3's batches (:mod:`models.peers.batching`: no dynamic body twice in a batch);
* ``iterations`` contact passes, then ``iterations`` friction passes, each pass one launch per batch, a thread per
  manifold (it reads its two bodies, solves the manifold's 4 points or 2 tangents, writes its dynamic bodies back);
* one integration launch, a thread per body.

Arithmetic: exactly the golden model's (``models/OPERATION_ORDER.md``: every ``+ - * /``, ``sqrt``, ``min``,
``max`` in that order and parenthesisation, the constants rounded to float32 on the host), compiled with Warp's
module options ``fuse_fp=False`` (no FMA contraction: LLVM ``FPOpFusion::Strict`` on the CPU, ``--fmad=false`` for
NVRTC on CUDA) and ``fast_math=False`` (IEEE division and square root on CUDA, no flush to zero). On the CPU Warp
compiles for generic x86-64 (SSE2, no FMA instructions at all). ``min``/``max`` are written as IEEE 754-2019
``minimum``/``maximum`` (NaN propagates, -0 < +0) as the golden model defines them. So every operation is IEEE
binary32 with round to nearest even, per operation, as in the golden model, with one difference: the golden model
flushes subnormal results and operands to zero (the Xilinx operators' rule), IEEE hardware keeps them. A step whose
golden run raises no underflow event (``models.formats.number_format.CountingFormat``) meets no subnormal, and there
Warp and the golden model run in the same order are equal bit for bit (:func:`compare_with_golden` checks it and reports
the events); where underflows occur the two may differ, by amounts that start below 1.2e-38 (the smallest normal
float32) per affected operation and are not bounded further here.

Devices: the CPU path is Warp's, serial and single-threaded (a launch runs its threads one after the other; Warp has
no multi-core CPU back end): label its times "1 thread". :func:`default_device` picks ``"cuda"`` when
``wp.get_cuda_device_count() > 0``: the same kernels run unchanged there, and :meth:`WarpPgs.time_step` times the
step with CUDA events (the kernels alone, from Warp's per-kernel activity timing, and the launch overhead apart:
eager launches from Python and a CUDA graph of the whole step). The CUDA path has not been measured in this project
(no GPU was available): its figures come only from running it where a GPU is.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass
from typing import Any, Optional

import numpy as np
import warp as wp

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import SPIN_DAMP_FACTOR, Impulses, SolverParams
from models.golden.integrator import (COS_COEFFS, MAX_ANGLE, SIN_COEFFS, SMALL_ANGLE, TAYLOR_SINC, IntegrationParams)
from models.formats.number_format import FP32, CountingFormat, FpEvents
from models.peers.batching import Batches

wp.config.quiet = True
# IEEE per-operation rounding: no FMA contraction, no fast math (module-wide: every kernel below)
wp.set_module_options({"fuse_fp": False, "fast_math": False, "enable_backward": False})


# --- the operations of models/OPERATION_ORDER.md ------------------------------------------------------------------
@wp.func
def dot3(a: wp.vec3, b: wp.vec3) -> float:
    return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]


@wp.func
def cross3(a: wp.vec3, b: wp.vec3) -> wp.vec3:
    return wp.vec3(a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@wp.func
def negate(x: float) -> float:
    """IEEE negation (the sign bit flipped): Warp's unary minus is ``0 - x``, which turns -(+0) into +0."""
    return x * -1.0


@wp.func
def ieee_max(a: float, b: float) -> float:
    """IEEE 754-2019 maximum: NaN propagates, +0 above -0."""
    if wp.isnan(a) or wp.isnan(b):
        return a + b
    if a > b:
        return a
    if b > a:
        return b
    if a == 0.0:
        return a + b  # equal zeros: -0 only when both are -0
    return a


@wp.func
def ieee_min(a: float, b: float) -> float:
    """IEEE 754-2019 minimum: NaN propagates, -0 below +0."""
    if wp.isnan(a) or wp.isnan(b):
        return a + b
    if a < b:
        return a
    if b < a:
        return b
    if a == 0.0:
        return negate(negate(a) + negate(b))  # equal zeros: +0 only when both are +0
    return a


@wp.func
def inertia_mul(inv_inertia: wp.array2d(dtype=float), body: int, c: wp.vec3, full: int) -> wp.vec3:
    """I^-1 c: per component for a diagonal (3 words), the symmetric 3x3 (6 words: xx yy zz xy xz yz) otherwise."""
    if full == 0:
        return wp.vec3(inv_inertia[body, 0] * c[0], inv_inertia[body, 1] * c[1], inv_inertia[body, 2] * c[2])
    xx = inv_inertia[body, 0]
    yy = inv_inertia[body, 1]
    zz = inv_inertia[body, 2]
    xy = inv_inertia[body, 3]
    xz = inv_inertia[body, 4]
    yz = inv_inertia[body, 5]
    return wp.vec3((xx * c[0] + xy * c[1]) + xz * c[2], (xy * c[0] + yy * c[1]) + yz * c[2],
                   (xz * c[0] + yz * c[1]) + zz * c[2])


@wp.func
def load_velocities(lin_vel: wp.array(dtype=wp.vec3), ang_vel: wp.array(dtype=wp.vec3), a: int, b: int):
    """A manifold's read of its bodies' velocities: vA, wA, vB, wB."""
    return lin_vel[a], ang_vel[a], lin_vel[b], ang_vel[b]


@wp.func
def store_velocities(lin_vel: wp.array(dtype=wp.vec3), ang_vel: wp.array(dtype=wp.vec3), body: int,
                     inv_mass: float, v: wp.vec3, w: wp.vec3):
    """A manifold's write-back of one body: a dynamic body's new velocities (a static body is read, never written)."""
    if inv_mass != 0.0:
        lin_vel[body] = v
        ang_vel[body] = w


@wp.kernel
def contact_batch(offset: int, body_a: wp.array(dtype=int), body_b: wp.array(dtype=int),
                  normal: wp.array(dtype=wp.vec3), points: wp.array2d(dtype=wp.vec3), jac_inv: wp.array2d(dtype=float),
                  bias: wp.array2d(dtype=float), lam: wp.array2d(dtype=float), position: wp.array(dtype=wp.vec3),
                  lin_vel: wp.array(dtype=wp.vec3), ang_vel: wp.array(dtype=wp.vec3), inv_mass: wp.array(dtype=float),
                  inv_inertia: wp.array2d(dtype=float), full: int):
    """One manifold of a batch through the contact pass (models.golden.contact_solver.contact_solve)."""
    m = offset + wp.tid()
    a = body_a[m]
    b = body_b[m]
    n = normal[m]
    xa = position[a]
    xb = position[b]
    va, wa, vb, wb = load_velocities(lin_vel, ang_vel, a, b)
    ma = inv_mass[a]
    mb = inv_mass[b]
    lin_a = n * ma
    lin_b = n * mb
    for i in range(4):
        jac = jac_inv[m, i]
        if jac != 0.0:
            p = points[m, i]
            ca = cross3(p - xa, n)
            cb = cross3(p - xb, n)
            vrel = (dot3(n, va) - dot3(n, vb)) + (dot3(ca, wa) - dot3(cb, wb))
            delta = (vrel + bias[m, i]) * jac
            old = lam[m, i]
            new = ieee_max(old + delta, 0.0)
            delta = new - old
            lam[m, i] = new
            va = va + lin_a * delta
            wa = wa + inertia_mul(inv_inertia, a, ca, full) * delta
            vb = vb - lin_b * delta
            wb = wb - inertia_mul(inv_inertia, b, cb, full) * delta
    store_velocities(lin_vel, ang_vel, a, ma, va, wa)
    store_velocities(lin_vel, ang_vel, b, mb, vb, wb)


@wp.kernel
def friction_batch(offset: int, body_a: wp.array(dtype=int), body_b: wp.array(dtype=int),
                   normal: wp.array(dtype=wp.vec3), center: wp.array(dtype=wp.vec3),
                   tangent: wp.array2d(dtype=wp.vec3), f_jac_inv: wp.array2d(dtype=float),
                   spin_damp: wp.array(dtype=int), mu: wp.array(dtype=float), lam: wp.array2d(dtype=float),
                   lam_t: wp.array2d(dtype=float), position: wp.array(dtype=wp.vec3), lin_vel: wp.array(dtype=wp.vec3),
                   ang_vel: wp.array(dtype=wp.vec3), inv_mass: wp.array(dtype=float),
                   inv_inertia: wp.array2d(dtype=float), full: int, spin_k: float):
    """One manifold of a batch through the friction pass (models.golden.contact_solver.friction_solve)."""
    m = offset + wp.tid()
    if f_jac_inv[m, 0] == 0.0:
        return
    a = body_a[m]
    b = body_b[m]
    va, wa, vb, wb = load_velocities(lin_vel, ang_vel, a, b)
    ma = inv_mass[a]
    mb = inv_mass[b]
    limit = mu[m] * ((lam[m, 0] + lam[m, 1]) + (lam[m, 2] + lam[m, 3]))
    neg_limit = negate(limit)
    c = center[m]
    ra = c - position[a]
    rb = c - position[b]
    for j in range(2):
        t = tangent[m, j]
        ca = cross3(ra, t)
        cb = cross3(rb, t)
        u = (dot3(t, va) - dot3(t, vb)) + (dot3(ca, wa) - dot3(cb, wb))
        delta = negate(u) * f_jac_inv[m, j]
        old = lam_t[m, j]
        new = ieee_min(ieee_max(old + delta, neg_limit), limit)
        delta = new - old
        lam_t[m, j] = new
        e = negate(delta)
        va = va + (t * ma) * e
        wa = wa + inertia_mul(inv_inertia, a, ca, full) * e
        vb = vb - (t * mb) * e
        wb = wb - inertia_mul(inv_inertia, b, cb, full) * e
    if spin_damp[m] != 0:
        n = normal[m]
        wa = wa - n * (dot3(n, wa) * spin_k)
        wb = wb - n * (dot3(n, wb) * spin_k)
    store_velocities(lin_vel, ang_vel, a, ma, va, wa)
    store_velocities(lin_vel, ang_vel, b, mb, vb, wb)


@wp.struct
class IntegrationConstants:
    """The integrator's run constants, each rounded to float32 once (models.golden.integrator.integrate)."""

    dt: float
    half_dt: float
    dt3c: float
    g_dt: wp.vec3
    max_angle: float
    damping: float
    small: float
    s3: float
    s5: float
    s7: float
    c2: float
    c4: float
    c6: float
    c8: float


@wp.kernel
def integrate_bodies(k: IntegrationConstants, inv_mass: wp.array(dtype=float), position: wp.array(dtype=wp.vec3),
                     orientation: wp.array(dtype=wp.vec4), lin_vel: wp.array(dtype=wp.vec3),
                     ang_vel: wp.array(dtype=wp.vec3)):
    """Bullet GPU's integrateSingleTransform for one dynamic body (models.golden.integrator.integrate)."""
    i = wp.tid()
    if inv_mass[i] == 0.0:
        return
    w = ang_vel[i] * k.damping
    theta = wp.sqrt((w[0] * w[0] + w[1] * w[1]) + w[2] * w[2])
    if theta * k.dt > k.max_angle:
        theta = k.max_angle / k.dt
    x = theta * k.half_dt
    x2 = x * x
    sin_x = x + x * (x2 * (k.s3 + x2 * (k.s5 + x2 * k.s7)))
    cos_x = 1.0 + x2 * (k.c2 + x2 * (k.c4 + x2 * (k.c6 + x2 * k.c8)))
    s = float(0.0)
    if theta < k.small:
        s = k.half_dt - (k.dt3c * theta) * theta
    else:
        s = sin_x / theta
    dx = w[0] * s
    dy = w[1] * s
    dz = w[2] * s
    dw = cos_x
    q = orientation[i]
    qx = (dw * q[0] + dx * q[3]) + (dy * q[2] - dz * q[1])
    qy = (dw * q[1] + dy * q[3]) + (dz * q[0] - dx * q[2])
    qz = (dw * q[2] + dz * q[3]) + (dx * q[1] - dy * q[0])
    qw = (dw * q[3] - dx * q[0]) - (dy * q[1] + dz * q[2])
    inv = 1.0 / wp.sqrt((qx * qx + qy * qy) + (qz * qz + qw * qw))
    orientation[i] = wp.vec4(qx * inv, qy * inv, qz * inv, qw * inv)
    ang_vel[i] = w
    v = lin_vel[i]
    position[i] = position[i] + v * k.dt
    lin_vel[i] = v + k.g_dt


@wp.kernel
def _empty(x: wp.array(dtype=float)):
    """A kernel that does nothing: what one launch costs on its own."""
    i = wp.tid()
    if i < 0:
        x[0] = 0.0


def default_device() -> str:
    """``"cuda"`` where Warp sees a CUDA device, else ``"cpu"``."""
    return "cuda" if wp.get_cuda_device_count() > 0 else "cpu"


def device_label(device: str) -> str:
    """The device in words: the card's name, or Warp's serial CPU path."""
    d = wp.get_device(device)
    if d.is_cuda:
        return f"{d.name} (CUDA, Warp {wp.__version__})"
    return f"CPU, 1 thread (Warp {wp.__version__} serial CPU path, LLVM, generic x86-64)"


def _f32(x: Any) -> np.ndarray:
    return np.ascontiguousarray(np.asarray(x, dtype=np.float64).astype(np.float32))


def integration_constants(ip: IntegrationParams) -> IntegrationConstants:
    """The integrator's constants as the golden model rounds them (float32, computed once, in its order)."""
    ar = FP32
    k = IntegrationConstants()
    dt = ar.const(ip.dt)
    k.dt = float(dt)
    k.half_dt = float(ar.mul(ar.const(0.5), dt))
    k.dt3c = float(ar.mul(ar.mul(ar.mul(dt, dt), dt), ar.const(TAYLOR_SINC)))
    k.g_dt = wp.vec3(*[float(x) for x in ar.mul(ar.const(np.asarray(ip.gravity, dtype=np.float64)), dt)])
    k.max_angle = float(ar.const(MAX_ANGLE))
    k.damping = float(ar.const(ip.damping))
    k.small = float(ar.const(SMALL_ANGLE))
    k.s3, k.s5, k.s7 = (float(ar.const(c)) for c in SIN_COEFFS)
    k.c2, k.c4, k.c6, k.c8 = (float(ar.const(c)) for c in COS_COEFFS)
    return k


@dataclass(frozen=True)
class StepTiming:
    """One step's time on a device (median over ``runs``), the kernels and the launch overhead apart (ms)."""

    device: str  # in words (device_label)
    runs: int
    launches: int  # kernel launches per step
    step_ms: float  # the step as a user gets it: CPU wall time; CUDA: a CUDA graph of the step, by CUDA events
    kernel_ms: float  # the kernels alone
    launch_ms: float  # step_ms - kernel_ms: the launches' cost
    eager_ms: Optional[float] = None  # CUDA: host wall time of the step launched from Python without a graph
    how: str = ""  # how the figures were taken


class WarpPgs:
    """One frame's step in Warp: bodies and constraints uploaded once (float32, constraints in batch order)."""

    def __init__(self, bodies: BodyTable, cons: ConstraintSet, batches: Batches, params: SolverParams = SolverParams(),
                 ip: IntegrationParams = IntegrationParams(), device: Optional[str] = None):
        if params.interleaved or params.soft_keep is not None or params.shock_contact or params.shock_friction:
            raise ValueError("the Warp peer runs Bullet's scheme: contact passes, then friction passes, rigid rows")
        if batches.order.shape != (cons.num_manifolds,):
            raise ValueError(f"batches hold {batches.order.shape[0]} manifolds, the constraints {cons.num_manifolds}")
        self.device = device or default_device()
        self.batches = batches
        self.params = params
        self.constants = integration_constants(ip)
        self.full = int(bodies.inv_inertia.shape[1] == 6)
        self._initial = {name: _f32(getattr(bodies, name)) for name in
                         ("position", "orientation", "linear_velocity", "angular_velocity")}
        self._upload(bodies, cons)
        self._commands = self._record()

    # --- set-up -----------------------------------------------------------------------------------------------
    def _array(self, values: np.ndarray, dtype: Any) -> wp.array:
        return wp.array(values, dtype=dtype, device=self.device)

    def _upload(self, bodies: BodyTable, cons: ConstraintSet) -> None:
        o = self.batches.order
        v3, f = wp.vec3, wp.float32
        mu = (cons.friction[:, 0] if cons.per_manifold_friction
              else np.full(cons.num_manifolds, FP32.const(self.params.friction_coeff)))
        self.body_a = self._array(cons.body_a[o].astype(np.int32), wp.int32)
        self.body_b = self._array(cons.body_b[o].astype(np.int32), wp.int32)
        self.normal = self._array(_f32(cons.normal[o]), v3)
        self.points = self._array(_f32(cons.points[o]), v3)
        self.jac_inv = self._array(_f32(cons.jac_inv[o]), f)
        self.bias = self._array(_f32(cons.bias[o]), f)
        self.center = self._array(_f32(cons.center[o]), v3)
        self.tangent = self._array(_f32(cons.tangent[o]), v3)
        self.f_jac_inv = self._array(_f32(cons.f_jac_inv[o]), f)
        self.spin_damp = self._array(cons.spin_damp[o].astype(np.int32), wp.int32)
        self.mu = self._array(_f32(mu[o]), f)
        self.lam = wp.zeros((cons.num_manifolds, 4), dtype=f, device=self.device)
        self.lam_t = wp.zeros((cons.num_manifolds, 2), dtype=f, device=self.device)
        self.inv_mass = self._array(_f32(bodies.inv_mass), f)
        self.inv_inertia = self._array(_f32(bodies.inv_inertia), f)
        self.position = self._array(self._initial["position"], v3)
        self.orientation = self._array(self._initial["orientation"], wp.vec4)
        self.lin_vel = self._array(self._initial["linear_velocity"], v3)
        self.ang_vel = self._array(self._initial["angular_velocity"], v3)
        self._pristine = {name: wp.clone(getattr(self, name)) for name in
                          ("position", "orientation", "lin_vel", "ang_vel")}

    def _record(self) -> list[Any]:
        """The step's launches, recorded once (``record_cmd``): the batches of each pass, then the integration."""
        off, sizes = self.batches.offsets, self.batches.sizes
        spin_k = float(FP32.const(SPIN_DAMP_FACTOR))
        contact = [wp.launch(contact_batch, dim=int(sizes[k]), device=self.device, record_cmd=True,
                             inputs=[int(off[k]), self.body_a, self.body_b, self.normal, self.points, self.jac_inv,
                                     self.bias, self.lam, self.position, self.lin_vel, self.ang_vel, self.inv_mass,
                                     self.inv_inertia, self.full])
                   for k in range(self.batches.num_batches)]
        friction = [wp.launch(friction_batch, dim=int(sizes[k]), device=self.device, record_cmd=True,
                              inputs=[int(off[k]), self.body_a, self.body_b, self.normal, self.center, self.tangent,
                                      self.f_jac_inv, self.spin_damp, self.mu, self.lam, self.lam_t, self.position,
                                      self.lin_vel, self.ang_vel, self.inv_mass, self.inv_inertia, self.full, spin_k])
                    for k in range(self.batches.num_batches)]
        integrate = wp.launch(integrate_bodies, dim=self.inv_mass.shape[0], device=self.device, record_cmd=True,
                              inputs=[self.constants, self.inv_mass, self.position, self.orientation, self.lin_vel,
                                      self.ang_vel])
        it = self.params.iterations
        return contact * it + friction * it + [integrate]

    # --- the step ---------------------------------------------------------------------------------------------
    @property
    def launches(self) -> int:
        return len(self._commands)

    def reset(self) -> None:
        """Back to the frame's state: the bodies as uploaded, the accumulated impulses zero."""
        for name, src in self._pristine.items():
            wp.copy(getattr(self, name), src)
        self.lam.zero_()
        self.lam_t.zero_()

    def step(self) -> None:
        """Launch the step (all passes and the integration) on the device; asynchronous on CUDA."""
        for cmd in self._commands:
            cmd.launch()

    def run(self) -> tuple[BodyTable, Impulses]:
        """Reset, step, and read back: the integrated bodies and the impulses (frame order), as float64 arrays."""
        self.reset()
        self.step()
        wp.synchronize_device(self.device)
        return self.result()

    def result(self) -> tuple[BodyTable, Impulses]:
        """The bodies and the accumulated impulses (frame order) as they are now."""
        o = self.batches.order
        normal = np.zeros((o.shape[0], 4))
        friction = np.zeros((o.shape[0], 2))
        normal[o] = self.lam.numpy()
        friction[o] = self.lam_t.numpy()
        table = BodyTable(position=self.position.numpy().astype(np.float64),
                          orientation=self.orientation.numpy().astype(np.float64),
                          linear_velocity=self.lin_vel.numpy().astype(np.float64),
                          angular_velocity=self.ang_vel.numpy().astype(np.float64),
                          inv_mass=self.inv_mass.numpy().astype(np.float64),
                          inv_inertia=self.inv_inertia.numpy().astype(np.float64))
        return table, Impulses(normal=normal, friction=friction)

    # --- timing -----------------------------------------------------------------------------------------------
    def time_step(self, runs: int = 7) -> StepTiming:
        """The step's median time over ``runs`` (after one warm-up run that compiles and loads the kernels)."""
        if runs < 1:
            raise ValueError(f"runs must be >= 1, got {runs}")
        self.run()
        if wp.get_device(self.device).is_cuda:
            return self._time_cuda(runs)
        return self._time_cpu(runs)

    def _time_cpu(self, runs: int) -> StepTiming:
        walls = []
        for _ in range(runs):
            self.reset()
            t0 = time.perf_counter()
            self.step()
            walls.append(time.perf_counter() - t0)
        per_launch = empty_launch_seconds(self.device, runs=max(runs, 5) * 20)
        step = statistics.median(walls) * 1e3
        overhead = per_launch * self.launches * 1e3
        return StepTiming(device_label(self.device), runs, self.launches, step, step - overhead, overhead, None,
                          f"wall time of the step (launches are synchronous on the CPU), median of {runs}; launch "
                          f"overhead = {self.launches} launches x the median time of an empty 1-thread launch "
                          f"({per_launch * 1e6:.1f} us), kernels = step - overhead")

    def _time_cuda(self, runs: int) -> StepTiming:
        device = wp.get_device(self.device)
        eager, graph_ms, kernels = [], [], []
        for _ in range(runs):
            self.reset()
            wp.synchronize_device(device)
            wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
            t0 = time.perf_counter()
            self.step()
            wp.synchronize_device(device)
            eager.append((time.perf_counter() - t0) * 1e3)
            kernels.append(sum(r.elapsed for r in wp.timing_end()))
        with wp.ScopedCapture(device=device) as capture:
            self.step()
        start, end = wp.Event(device, enable_timing=True), wp.Event(device, enable_timing=True)
        for _ in range(runs):
            self.reset()
            wp.synchronize_device(device)
            wp.record_event(start)
            wp.capture_launch(capture.graph)
            wp.record_event(end)
            wp.synchronize_event(end)
            graph_ms.append(wp.get_event_elapsed_time(start, end))
        step, kernel = statistics.median(graph_ms), statistics.median(kernels)
        return StepTiming(device_label(self.device), runs, self.launches, step, kernel, step - kernel,
                          statistics.median(eager),
                          f"step = a CUDA graph of its {self.launches} launches, timed by CUDA events; kernels = the "
                          f"sum of Warp's per-kernel CUDA-event timings (TIMING_KERNEL); launch overhead = step - "
                          f"kernels; eager = host wall time of the same launches from Python; medians of {runs}")


def empty_launch_seconds(device: str, runs: int = 200) -> float:
    """The median time of one launch of an empty 1-thread kernel (recorded, as the step's launches are)."""
    x = wp.zeros(1, dtype=wp.float32, device=device)
    cmd = wp.launch(_empty, dim=1, inputs=[x], device=device, record_cmd=True)
    cmd.launch()
    wp.synchronize_device(device)
    times = []
    for _ in range(runs):
        t0 = time.perf_counter()
        cmd.launch()
        wp.synchronize_device(device)
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


# --- the check against the golden model -----------------------------------------------------------------------------
@dataclass(frozen=True)
class GoldenAgreement:
    """Warp's step against the golden model's in the same order: float32 words compared bit for bit."""

    words: int  # float32 words compared (bodies: position, orientation, velocities; impulses)
    differing_words: int
    max_abs_difference: float
    first_difference: str  # "" when none
    events: FpEvents  # the golden run's overflow / underflow / invalid events

    @property
    def bit_exact(self) -> bool:
        return self.differing_words == 0

    def describe(self) -> str:
        head = (f"{self.differing_words:,} of {self.words:,} float32 words differ" if self.differing_words
                else f"bit-exact: 0 of {self.words:,} float32 words differ")
        ev = self.events
        tail = (f"; golden run: {ev.underflow} underflow, {ev.overflow} overflow, {ev.invalid} invalid events "
                f"(no underflow: no subnormal, the arithmetic is the same)")
        first = f"; first: {self.first_difference}, max |difference| {self.max_abs_difference:.3e}" \
            if self.differing_words else ""
        return head + first + tail


def _bits(x: np.ndarray) -> np.ndarray:
    """float32 bit patterns, every NaN as the canonical quiet NaN."""
    f = np.asarray(x, dtype=np.float64).astype(np.float32)
    bits = f.view(np.uint32).copy()
    bits[np.isnan(f)] = 0x7FC00000
    return bits


def golden_same_order(bodies32: BodyTable, cons32: ConstraintSet, batches: Batches, params: SolverParams,
                      ip: IntegrationParams) -> tuple[BodyTable, Impulses, FpEvents]:
    """The golden model's step in fp32 with the batches concatenated as its schedule, counting its events."""
    from models.golden.contact_solver import solve
    from models.golden.integrator import integrate

    fmt: CountingFormat = FP32.counting()
    solved = solve(bodies32, cons32, batches.order, fmt, params)
    return integrate(solved.bodies, fmt, ip), solved.impulses, fmt.events


def compare_with_golden(ours: tuple[BodyTable, Impulses], golden: tuple[BodyTable, Impulses],
                        events: FpEvents) -> GoldenAgreement:
    """Every float32 word of Warp's step against the golden model's (bodies, then impulses)."""
    fields_: list[tuple[str, np.ndarray, np.ndarray]] = [
        (name, getattr(ours[0], name), getattr(golden[0], name))
        for name in ("position", "orientation", "linear_velocity", "angular_velocity")]
    fields_ += [("normal impulse", ours[1].normal, golden[1].normal),
                ("friction impulse", ours[1].friction, golden[1].friction)]
    words = differing = 0
    worst, first = 0.0, ""
    for name, a, b in fields_:
        diff = _bits(a) != _bits(b)
        words += diff.size
        n = int(np.count_nonzero(diff))
        if n:
            differing += n
            with np.errstate(invalid="ignore"):
                worst = max(worst, float(np.nanmax(np.abs(np.asarray(a, float) - np.asarray(b, float))[diff])))
            if not first:
                idx = tuple(int(i) for i in np.argwhere(diff)[0])
                first = f"{name}{list(idx)}: Warp {float(a[idx])!r} vs golden {float(b[idx])!r}"
    return GoldenAgreement(words, differing, worst, first, events)

