"""The catalogue of test scenes: what each scene is made of (boxes, masses, poses, velocities), built from
its parameters.

Every scene is y-up; every body is a box; the static ground box comes first, so it is frame body 0 (as in
Bullet's GPU demo), and frame body index i is the i-th body of :attr:`SceneSpec.bodies`. Friction: the scene
parameter ``friction`` is the *pair* coefficient (default 0.7, Bullet GPU's hard-coded value); how pybullet
is given it is ``models.scenes.world``'s business. Restitution is 0.

:func:`make_spec` validates the parameters (:class:`SceneError` names the bad one) and fills in the defaults;
``models.scenes.world`` builds the spec in pybullet, ``models.scenes.frame_cache`` caches its frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from models.scenes.scene_args import typed_params
from models.scenes.scene_error import SceneError

DEFAULT_FRICTION = 0.7
# the thesis scene's frame as captured here (per-body queries, the step the thesis solves): its 38,880 cubes and the
# ground, and the manifolds pybullet reports (the thesis counts 127,000: models/published/thesis.py)
THESIS_FRAME_BODIES = 38_881
THESIS_FRAME_MANIFOLDS = 147_485


@dataclass(frozen=True)
class BoxSpec:
    half_extents: tuple[float, float, float]
    mass: float  # 0 = static
    position: tuple[float, float, float]
    orientation: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 1.0)  # (x, y, z, w)
    linear_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class SceneSpec:
    bodies: list[BoxSpec]  # bodies[0] is the static ground
    friction: float  # pair friction coefficient
    params: dict[str, Any] = field(default_factory=dict)  # the resolved builder parameters


Builder = Callable[..., SceneSpec]


def _check(cond: bool, msg: str) -> None:
    if not cond:
        raise SceneError(msg)


def int_param(name: str, value: Any, lo: int, hi: int) -> int:
    _check(isinstance(value, (int, np.integer)) and not isinstance(value, bool) and lo <= value <= hi,
           f"parameter {name} must be an integer in [{lo}, {hi}], got {value!r}")
    return int(value)


def float_param(name: str, value: Any, lo: float, hi: float, lo_open: bool = False) -> float:
    ok = isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, bool)
    ok = ok and math.isfinite(float(value)) and (float(value) > lo if lo_open else float(value) >= lo)
    ok = ok and float(value) <= hi
    bracket = "(" if lo_open else "["
    _check(ok, f"parameter {name} must be a number in {bracket}{lo}, {hi}], got {value!r}")
    return float(value)


def _friction(value: Any) -> float:
    return float_param("friction", value, 0.0, 10.0)


def _ground(half: float = 50.0) -> BoxSpec:
    return BoxSpec((half, half, half), 0.0, (0.0, -half, 0.0))


def _quat_about_z(angle: float) -> tuple[float, float, float, float]:
    return (0.0, 0.0, math.sin(angle / 2), math.cos(angle / 2))


def _small_rotation(rng: np.random.Generator, max_angle: float) -> tuple[float, float, float, float]:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    angle = rng.uniform(-max_angle, max_angle)
    s = math.sin(angle / 2)
    return (float(axis[0] * s), float(axis[1] * s), float(axis[2] * s), math.cos(angle / 2))


def thesis_scene(rng: np.random.Generator, nx: int = 36, ny: int = 30, nz: int = 36, half_extent: float = 1.0,
                 mass: float = 1.0, ground_half_extent: float = 400.0,
                 friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """Bullet's GpuBoxPlaneScene (examples/OpenCL/rigidbody/GpuConvexScene.cpp) at the thesis' 36x30x36."""
    friction = _friction(friction)
    nx, ny, nz = (int_param(k, v, 1, 1000) for k, v in (("nx", nx), ("ny", ny), ("nz", nz)))
    _check(half_extent == 1.0, "parameter half_extent must be 1.0 for the thesis scene (the demo's cube)")
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    ground_half_extent = float_param("ground_half_extent", ground_half_extent, 1.0, 1e5)
    bodies = [_ground(ground_half_extent)]
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                off = float((j + 1) & 1)
                bodies.append(BoxSpec((1.0, 1.0, 1.0), mass, (off + 2.2 * i, 1.0 + 2.0 * j, off + 2.2 * k)))
    return SceneSpec(bodies, friction, dict(nx=nx, ny=ny, nz=nz, half_extent=half_extent, mass=mass,
                                                      ground_half_extent=ground_half_extent, friction=friction))


def pile_scene(rng: np.random.Generator, nx: int = 6, ny: int = 6, nz: int = 6, half_extent: float = 0.5,
               mass: float = 1.0, gap: float = 0.1, jitter: float = 0.02, jitter_angle: float = 0.03,
               stagger: bool = True, friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A jittered grid of cubes a little apart above the ground; they fall and settle into a pile.

    With ``stagger`` odd layers are shifted by half a pitch in x and z, so every cube lands on up to four
    cubes below and the outer ones topple (a pile rather than standing columns)."""
    friction = _friction(friction)
    nx, ny, nz = (int_param(k, v, 1, 100) for k, v in (("nx", nx), ("ny", ny), ("nz", nz)))
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    gap = float_param("gap", gap, 0.0, 10.0 * h)
    jitter = float_param("jitter", jitter, 0.0, 1.0)
    jitter_angle = float_param("jitter_angle", jitter_angle, 0.0, 0.5)
    _check(isinstance(stagger, (bool, np.bool_)), f"parameter stagger must be a bool, got {stagger!r}")
    # a rotation by a moves a corner by at most sqrt(3) h a: keep neighbours apart at the start
    _check(2 * (jitter + math.sqrt(3) * h * jitter_angle) < gap or (jitter == 0 and jitter_angle == 0),
           "parameters jitter/jitter_angle too large for gap: the cubes would start overlapping")
    pitch = 2 * h + gap
    bodies = [_ground()]
    for j in range(ny):
        for i in range(nx):
            for k in range(nz):
                off = 0.5 * pitch if (stagger and j % 2 == 1) else 0.0
                base = np.array([(i - (nx - 1) / 2) * pitch + off, h + gap / 2 + j * pitch, (k - (nz - 1) / 2) * pitch + off])
                pos = base + rng.uniform(-jitter, jitter, size=3)
                bodies.append(BoxSpec((h, h, h), mass, tuple(float(x) for x in pos), _small_rotation(rng, jitter_angle)))
    return SceneSpec(bodies, friction, dict(nx=nx, ny=ny, nz=nz, half_extent=h, mass=mass, gap=gap,
                                                      jitter=jitter, jitter_angle=jitter_angle, stagger=bool(stagger),
                                                      friction=friction))


def stack_scene(rng: np.random.Generator, n: int = 10, half_extent: float = 0.5, mass: float = 1.0, gap: float = 0.0,
                friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A tower of n cubes on the ground, touching (gap 0) or ``gap`` apart."""
    friction = _friction(friction)
    n = int_param("n", n, 1, 1000)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    gap = float_param("gap", gap, 0.0, 0.01)
    bodies = [_ground()] + [BoxSpec((h, h, h), mass, (0.0, h + gap + i * (2 * h + gap), 0.0)) for i in range(n)]
    return SceneSpec(bodies, friction, dict(n=n, half_extent=h, mass=mass, gap=gap, friction=friction))


def pyramid_scene(rng: np.random.Generator, n: int = 5, half_extent: float = 0.5, mass: float = 1.0,
                  gap: float = 0.02, friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A 2-D pyramid (in the x-y plane) with n cubes in the base row, rows touching, ``gap`` within a row."""
    friction = _friction(friction)
    n = int_param("n", n, 1, 100)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    gap = float_param("gap", gap, 0.0, 2 * h)
    pitch = 2 * h + gap
    bodies = [_ground()]
    for row in range(n):
        count = n - row
        for i in range(count):
            bodies.append(BoxSpec((h, h, h), mass, ((i - (count - 1) / 2) * pitch, h + row * 2 * h, 0.0)))
    return SceneSpec(bodies, friction, dict(n=n, half_extent=h, mass=mass, gap=gap, friction=friction))


def incline_scene(rng: np.random.Generator, angle_deg: float = 20.0, box_half_extents: tuple[float, ...] = (0.5, 0.25, 0.4),
                  mass: float = 1.0, slope_half_extents: tuple[float, ...] = (5.0, 0.5, 2.0),
                  friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A box resting on a static slope (a box rotated by angle_deg about z), aligned with it.

    The default box is not a cube, so its inertia is anisotropic (exercises I^-1_world = R diag R^T)."""
    friction = _friction(friction)
    angle_deg = float_param("angle_deg", angle_deg, 0.0, 80.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    _check(len(box_half_extents) == 3 and all(0.01 <= float(x) <= 10 for x in box_half_extents),
           f"parameter box_half_extents must be 3 numbers in [0.01, 10], got {box_half_extents!r}")
    _check(len(slope_half_extents) == 3 and all(0.1 <= float(x) <= 100 for x in slope_half_extents),
           f"parameter slope_half_extents must be 3 numbers in [0.1, 100], got {slope_half_extents!r}")
    hb = tuple(float(x) for x in box_half_extents)
    hs = tuple(float(x) for x in slope_half_extents)
    a = math.radians(angle_deg)
    normal = np.array([-math.sin(a), math.cos(a), 0.0])  # the slope's local +y
    lift = hs[0] * math.sin(a) + hs[1] * math.cos(a) + 0.1  # keep the slope clear of the ground
    top = np.array([0.0, lift, 0.0])  # centre of the slope's top face
    q = _quat_about_z(a)
    slope = BoxSpec(hs, 0.0, tuple(float(x) for x in top - hs[1] * normal), q)
    box = BoxSpec(hb, mass, tuple(float(x) for x in top + hb[1] * normal), q)
    return SceneSpec([_ground(), slope, box], friction,
                     dict(angle_deg=angle_deg, box_half_extents=list(hb), mass=mass, slope_half_extents=list(hs),
                          friction=friction))


def mass_ratio_scene(rng: np.random.Generator, ratio: float = 1000.0, half_extent: float = 0.5, light_mass: float = 1.0,
                     layers: int = 1, gap: float = 0.02, friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A heavy cube (ratio x light_mass, twice the size) resting on ``layers`` 2x2 layers of light cubes."""
    friction = _friction(friction)
    ratio = float_param("ratio", ratio, 0.0, 1e7, lo_open=True)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    light_mass = float_param("light_mass", light_mass, 0.0, 1e6, lo_open=True)
    layers = int_param("layers", layers, 1, 20)
    gap = float_param("gap", gap, 0.0, h)
    pitch = 2 * h + gap
    bodies = [_ground()]
    for layer in range(layers):
        for i in (-0.5, 0.5):
            for k in (-0.5, 0.5):
                bodies.append(BoxSpec((h, h, h), light_mass, (i * pitch, h + layer * 2 * h, k * pitch)))
    hh = 2 * h
    bodies.append(BoxSpec((hh, hh, hh), light_mass * ratio, (0.0, layers * 2 * h + hh, 0.0)))
    return SceneSpec(bodies, friction, dict(ratio=ratio, half_extent=h, light_mass=light_mass, layers=layers,
                                                      gap=gap, friction=friction))


def impact_scene(rng: np.random.Generator, speed: float = 20.0, base: int = 3, height: int = 2, half_extent: float = 0.5,
                 mass: float = 1.0, gap: float = 0.02, drop_gap: float = 0.01,
                 friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A cube moving down at ``speed`` m/s, ``drop_gap`` above a resting base x height x base block of cubes.

    pybullet's box-box detector makes no contact for separated boxes, so the hit shows in step 2 (at 20 m/s
    the cube has moved 0.33 m into the block: a deep contact that takes the split-impulse path)."""
    friction = _friction(friction)
    speed = float_param("speed", speed, 0.0, 1000.0)
    base = int_param("base", base, 1, 20)
    height = int_param("height", height, 1, 20)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    gap = float_param("gap", gap, 0.0, 2 * h)
    drop_gap = float_param("drop_gap", drop_gap, 0.0, 10.0)
    pitch = 2 * h + gap
    bodies = [_ground()]
    for j in range(height):
        for i in range(base):
            for k in range(base):
                bodies.append(BoxSpec((h, h, h), mass, ((i - (base - 1) / 2) * pitch, h + 2 * h * j,
                                                        (k - (base - 1) / 2) * pitch)))
    bodies.append(BoxSpec((h, h, h), mass, (0.0, 2 * h * height + drop_gap + h, 0.0), linear_velocity=(0.0, -speed, 0.0)))
    return SceneSpec(bodies, friction, dict(speed=speed, base=base, height=height, half_extent=h, mass=mass,
                                                      gap=gap, drop_gap=drop_gap, friction=friction))


def spin_scene(rng: np.random.Generator, spin: float = 15.0, height: float = 0.3, half_extent: float = 0.5,
               mass: float = 1.0, friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A cube spinning at ``spin`` rad/s about a tilted axis, released ``height`` above the ground (it lands on an
    edge or a corner while turning)."""
    friction = _friction(friction)
    spin = float_param("spin", spin, 0.0, 1000.0)
    height = float_param("height", height, 0.0, 100.0)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    axis = np.array([0.3, 1.0, 0.5]) / np.linalg.norm([0.3, 1.0, 0.5])
    box = BoxSpec((h, h, h), mass, (0.0, h * math.sqrt(3.0) + height, 0.0), _quat_about_z(0.4),
                  angular_velocity=tuple(float(x) for x in spin * axis))
    return SceneSpec([_ground(), box], friction, dict(spin=spin, height=height, half_extent=h, mass=mass,
                                                      friction=friction))


def plank_scene(rng: np.random.Generator, n: int = 5, plank_half_extents: tuple[float, ...] = (3.0, 0.1, 3.0),
                half_extent: float = 0.25, mass: float = 1.0, plank_mass: float = 10.0,
                friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """A dynamic plank on the ground carrying an n x n grid of cubes: one body with n*n + 1 manifolds."""
    friction = _friction(friction)
    n = int_param("n", n, 1, 20)
    _check(len(plank_half_extents) == 3 and all(0.01 <= float(x) <= 100 for x in plank_half_extents),
           f"parameter plank_half_extents must be 3 numbers in [0.01, 100], got {plank_half_extents!r}")
    hp = tuple(float(x) for x in plank_half_extents)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    plank_mass = float_param("plank_mass", plank_mass, 0.0, 1e6, lo_open=True)
    pitch = 2 * min(hp[0], hp[2]) / n
    _check(pitch > 2 * h, f"{n} x {n} cubes of half extent {h} do not fit on the plank")
    bodies = [_ground(), BoxSpec(hp, plank_mass, (0.0, hp[1], 0.0))]
    for i in range(n):
        for k in range(n):
            bodies.append(BoxSpec((h, h, h), mass, ((i - (n - 1) / 2) * pitch, 2 * hp[1] + h,
                                                    (k - (n - 1) / 2) * pitch)))
    return SceneSpec(bodies, friction, dict(n=n, plank_half_extents=list(hp), half_extent=h, mass=mass,
                                            plank_mass=plank_mass, friction=friction))


def degenerate_scene(rng: np.random.Generator, tilt: float = 1e-4, half_extent: float = 0.5, mass: float = 1.0,
                     friction: float = DEFAULT_FRICTION) -> SceneSpec:
    """Contacts that break solvers: a cube balanced on an edge (2 points), one on a corner (1 point), one tilted by
    ``tilt`` rad (a near-parallel face: 4 points at nearly the same depth), and one resting exactly on another
    (coincident corners)."""
    friction = _friction(friction)
    tilt = float_param("tilt", tilt, 0.0, 0.1)
    h = float_param("half_extent", half_extent, 0.01, 10.0)
    mass = float_param("mass", mass, 0.0, 1e6, lo_open=True)
    edge = _quat_about_z(math.pi / 4)
    # corner down: rotate the cube's (1,1,1) diagonal onto the vertical
    axis = np.cross([1.0, 1.0, 1.0], [0.0, 1.0, 0.0])
    axis /= np.linalg.norm(axis)
    ang = math.acos(1.0 / math.sqrt(3.0))
    corner = (*(float(x) * math.sin(ang / 2) for x in axis), math.cos(ang / 2))
    tilted = (math.sin(tilt / 2), 0.0, 0.0, math.cos(tilt / 2))
    bodies = [_ground(),
              BoxSpec((h, h, h), mass, (-3.0, h * math.sqrt(2.0), 0.0), edge),
              BoxSpec((h, h, h), mass, (0.0, h * math.sqrt(3.0), 0.0), corner),
              BoxSpec((h, h, h), mass, (3.0, h, 0.0), tilted),
              BoxSpec((h, h, h), mass, (6.0, h, 0.0)),
              BoxSpec((h, h, h), mass, (6.0, 3 * h, 0.0))]
    return SceneSpec(bodies, friction, dict(tilt=tilt, half_extent=h, mass=mass, friction=friction))


SCENES: dict[str, Builder] = {
    "thesis": thesis_scene,
    "pile": pile_scene,
    "stack": stack_scene,
    "pyramid": pyramid_scene,
    "incline": incline_scene,
    "mass_ratio": mass_ratio_scene,
    "impact": impact_scene,
    "spin": spin_scene,
    "plank": plank_scene,
    "degenerate": degenerate_scene,
}

# the step captured when neither step nor busiest_within is given (1-based: step s is the s-th stepSimulation)
DEFAULT_CAPTURE_STEP: dict[str, int] = {
    "thesis": 3, "pile": 40, "stack": 10, "pyramid": 10, "incline": 10, "mass_ratio": 10, "impact": 2, "spin": 20,
    "plank": 10, "degenerate": 2,
}


def make_spec(scene: str, seed: int = 0, **params: Any) -> SceneSpec:
    _check(scene in SCENES, f"unknown scene {scene!r}; known: {', '.join(SCENES)}")
    _check(isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0,
           f"seed must be a non-negative integer, got {seed!r}")
    builder = SCENES[scene]
    params = typed_params(builder, params, scene, lead=1)  # SCENE_ARGS strings typed; an unknown key named
    try:
        return builder(np.random.default_rng(int(seed)), **params)
    except TypeError as exc:  # unknown keyword
        raise SceneError(f"bad parameter for scene {scene!r}: {exc}") from None

