"""The kernel's three datapaths as dataflow graphs, in the operation order of models/golden/OPERATION_ORDER.md.

Each function mirrors the golden Python line by line (``models/golden/contact_solver.py``:
``contact_solve``, ``friction_solve``, ``dot3``, ``cross3``, ``scale3``, ``_apply``;
``models/golden/integrator.py``: ``integrate``, ``sin_poly``, ``cos_poly``, ``quat_mul``): the same
operations with the same association order, so the generated RTL is bit-identical to it. The
golden's masked updates (``np.where(active, new, old)``) become selects.

Word layouts (``in_data`` / ``out_data``) are the port contract of the generated modules; the test
harness packs them with ``models/kernel/kernel_vectors.py``.

The contact and friction graphs come in the inverse-inertia modes of ``models/setup/inertia.py``: ``inertia_words`` 3
(the kernel's build, ports ``IInvA_x..z``: one multiply per component), 1 (``IInvA_s``: the body's one value
times each component) or 6 (``IInvA_xx, _yy, _zz, _xy, _xz, _yz``: the symmetric 3x3 product,
``models.setup.inertia.inertia_product``); the friction graph with ``manifold_friction`` takes the manifold's
coefficient as a word ``mu`` after the bodies' words in place of the constant. The 3-word builds without a
friction word are the kernel's default pipes (:data:`GRAPHS`); the 1- and 6-word builds (:data:`MODE_GRAPHS`), which
the kernel instantiates for its ``IINV_W`` parameter, are generated into ``rtl/generated`` beside them.
"""

from __future__ import annotations

from functools import partial
from typing import Callable

from models.golden.contact_solver import FRICTION_COEFF, SPIN_DAMP_FACTOR
from models.setup.inertia import FULL_ORDER, InertiaMode
from models.golden.integrator import COS_COEFFS, MAX_ANGLE, SIN_COEFFS, SMALL_ANGLE, TAYLOR_SINC
from models.formats.number_format import KERNEL_FORMATS
from models.setup.tangent_basis import PLANE_SPACE_SPLIT

from rtl.gen.dataflow import Graph, Value
from rtl.gen.shared_datapath import SharedDatapath, SharedLayout

# The mantissa width of each kernel format (models.formats.number_format.KERNEL_FORMATS). The golden model's constants
# above (float64 values) are rounded to the format in the RTL.
MAN_BITS_OF = {name: fmt.man_bits for name, fmt in KERNEL_FORMATS.items()}

Vec = list[Value]


# --- helpers: the golden's vector operation order -------------------------------------------------
def dot3(a: Vec, b: Vec) -> Value:
    """(a.x*b.x + a.y*b.y) + a.z*b.z"""
    return (a[0] * b[0] + a[1] * b[1]) + a[2] * b[2]


def cross3(a: Vec, b: Vec) -> Vec:
    """(a.y*b.z - a.z*b.y, a.z*b.x - a.x*b.z, a.x*b.y - a.y*b.x)"""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def scale3(v: Vec, s: Value) -> Vec:
    """v * s per component (v.k * s)."""
    return [v[k] * s for k in range(3)]


def vmul(a: Vec, b: Vec) -> Vec:
    return [a[k] * b[k] for k in range(3)]


def vadd(a: Vec, b: Vec) -> Vec:
    return [a[k] + b[k] for k in range(3)]


def vsub(a: Vec, b: Vec) -> Vec:
    return [a[k] - b[k] for k in range(3)]


def vselect(g: Graph, p: Value, a: Vec, b: Vec) -> Vec:
    return [g.select(p, a[k], b[k]) for k in range(3)]


def named(vs: Vec, name: str) -> Vec:
    return [v.named(f"{name}_{'xyzw'[k]}") for k, v in enumerate(vs)]


# --- inverse inertia: the words of each mode and the angular update I^-1 c ---------------------------------------
INERTIA_COMPONENTS: dict[int, tuple[str, ...]] = {1: ("s",), 3: ("x", "y", "z"), 6: FULL_ORDER}
_MODE_OF_WORDS = {m.words: m for m in InertiaMode}


def inertia_ports(inertia_words: int) -> list[str]:
    """The inverse-inertia input ports of both bodies (A's words, then B's)."""
    if inertia_words not in INERTIA_COMPONENTS:
        raise ValueError(f"a pipe takes 1, 3 or 6 inverse-inertia words per body, got {inertia_words}")
    return [f"IInv{s}_{c}" for s in "AB" for c in INERTIA_COMPONENTS[inertia_words]]


def inertia_inputs(g: Graph, body: str, inertia_words: int) -> list[Value]:
    return [g.input(f"IInv{body}_{c}") for c in INERTIA_COMPONENTS[inertia_words]]


def inertia_mul(i: list[Value], c: Vec) -> Vec:
    """I^-1 c in models.setup.inertia.inertia_product's order: per component for a scalar or a diagonal,
    ((Ixx cx + Ixy cy) + Ixz cz, (Ixy cx + Iyy cy) + Iyz cz, (Ixz cx + Iyz cy) + Izz cz) for the full matrix."""
    if len(i) == 1:
        return [i[0] * c[k] for k in range(3)]
    if len(i) == 3:
        return vmul(i, c)
    xx, yy, zz, xy, xz, yz = i
    return [(xx * c[0] + xy * c[1]) + xz * c[2], (xy * c[0] + yy * c[1]) + yz * c[2],
            (xz * c[0] + yz * c[1]) + zz * c[2]]


def pipe_module(base: str, inertia_words: int, manifold_friction: bool = False) -> str:
    """``base`` for the kernel's build (3 words, the constant coefficient), else suffixed by the mode / ``_mu``."""
    inertia_ports(inertia_words)
    suffix = "" if inertia_words == 3 else f"_{_MODE_OF_WORDS[inertia_words].value}"
    return base + suffix + ("_mu" if manifold_friction else "")


# --- contact pass ------------------------------------------------------------------------------------
def contact_in(inertia_words: int = 3, soft: bool = False) -> list[str]:
    """The contact pipe's input words with ``inertia_words`` inverse-inertia words per body (and, for the soft
    contact pipe, the two per-call keep factors last)."""
    return (["n_x", "n_y", "n_z"] + [f"p{i}_{c}" for i in range(4) for c in "xyz"]
            + [f"jac_inv{i}" for i in range(4)] + [f"b{i}" for i in range(4)] + [f"lam{i}" for i in range(4)]
            + [f"{v}_{c}" for v in ("xA", "xB", "vA", "wA", "vB", "wB") for c in "xyz"]
            + ["mInvA", "mInvB"] + inertia_ports(inertia_words) + (list(SOFT_KEEP_WORDS) if soft else []))


# the soft contact pipe's two per-call constants (models.golden.contact_solver.SolverParams.soft_keep's order: a row
# between two dynamic bodies, a row with a static body), words after the inverse inertia
SOFT_KEEP_WORDS = ("keep_dyn", "keep_static")
SOFT_DOC = """

Soft contact (models/golden/soft_contact.py, SolverParams.soft_keep): with in_soft set, each point's accumulated
impulse is multiplied by its keep factor before the add, lam' = max(lam * keep + delta0, 0): keep is 1 where
b > 0 (a speculative point), else keep_static for a row with a static body (mInvA or mInvB zero) and keep_dyn
otherwise. With in_soft clear keep is 1 (a multiply by 1 is exact: the rigid update, bit for bit)."""


CONTACT_IN = contact_in()
CONTACT_OUT = ([f"lam{i}" for i in range(4)] + [f"{v}_{c}" for v in ("vA", "wA", "vB", "wB") for c in "xyz"])


def _soft_keeps(g: Graph, bias: list[Value], ma: Value, mb: Value) -> list[Value]:
    """Each point's keep factor (``models.golden.contact_solver._row_keep``), 1 where ``in_soft`` is clear."""
    kd, ks = (g.input(w) for w in SOFT_KEEP_WORDS)
    soft = g.bool_input("soft")
    one = g.const(1.0, "one")
    row = g.select(g.is_zero(ma, name="staticA"), ks, g.select(g.is_zero(mb, name="staticB"), ks, kd),
                   name="keep_row")
    return [g.select(soft, g.select(g.is_pos(bias[i], name=f"apart{i}"), one, row), one, name=f"keep{i}")
            for i in range(4)]


def contact_graph(inertia_words: int = 3, soft: bool = False) -> Graph:
    """The contact pass; ``soft``: the soft contact pipe (module suffix ``_soft``, the diagonal mode only), the
    accumulated impulse times a keep factor before the add (:data:`SOFT_DOC`)."""
    if soft and inertia_words != 3:
        raise ValueError(f"the soft contact pipe is built for 3 inverse-inertia words per body, got {inertia_words}")
    module = pipe_module("pgs_contact_pipe", inertia_words) + ("_soft" if soft else "")
    g = Graph(module, doc=f"""\
{module}: one contact pass of one manifold (models/golden/contact_solver.py contact_solve for a
single manifold; models/golden/OPERATION_ORDER.md "Contact pass"). The four points are solved in order,
point i+1 seeing point i's velocity update; a point with jac_inv == 0 is skipped (its lam and the
velocities keep their previous values: selects). The velocities of a static body are computed the
same way; the caller must not write them back.""" + _inertia_doc(inertia_words) + (SOFT_DOC if soft else ""))
    n = g.inputs_vec("n")
    p = [g.inputs_vec(f"p{i}") for i in range(4)]
    jac = [g.input(f"jac_inv{i}") for i in range(4)]
    bias = [g.input(f"b{i}") for i in range(4)]
    lam = [g.input(f"lam{i}") for i in range(4)]
    xa, xb = g.inputs_vec("xA"), g.inputs_vec("xB")
    va, wa = g.inputs_vec("vA"), g.inputs_vec("wA")
    vb, wb = g.inputs_vec("vB"), g.inputs_vec("wB")
    ma, mb = g.input("mInvA"), g.input("mInvB")
    ia, ib = inertia_inputs(g, "A", inertia_words), inertia_inputs(g, "B", inertia_words)
    keep = _soft_keeps(g, bias, ma, mb) if soft else None
    assert [v.name.removeprefix("in_") for v in g.inputs] == contact_in(inertia_words, soft)

    lin_a = named(scale3(n, ma), "linA")
    lin_b = named(scale3(n, mb), "linB")
    zero = g.const(0.0, "zero")
    for i in range(4):
        with g.scope(f"pt{i}"):
            skip = g.is_zero(jac[i], name="skip")
            ca = named(cross3(named(vsub(p[i], xa), "rA"), n), "cA")
            cb = named(cross3(named(vsub(p[i], xb), "rB"), n), "cB")
            vrel = ((dot3(n, va) - dot3(n, vb)) + (dot3(ca, wa) - dot3(cb, wb))).named("vrel")
            delta = ((vrel + bias[i]) * jac[i]).named("delta0")
            start = lam[i] if keep is None else (lam[i] * keep[i]).named("lam_kept")
            new = g.max(start + delta, zero, name="lam_new")
            delta = (new - lam[i]).named("delta")
            lam[i] = g.select(skip, lam[i], new, name="lam")
            ang_a = named(inertia_mul(ia, ca), "angA")
            ang_b = named(inertia_mul(ib, cb), "angB")
            va = named(vselect(g, skip, va, vadd(va, scale3(lin_a, delta))), "vA")
            wa = named(vselect(g, skip, wa, vadd(wa, scale3(ang_a, delta))), "wA")
            vb = named(vselect(g, skip, vb, vsub(vb, scale3(lin_b, delta))), "vB")
            wb = named(vselect(g, skip, wb, vsub(wb, scale3(ang_b, delta))), "wB")
    for i in range(4):
        g.output(f"lam{i}", lam[i])
    for name, v in (("vA", va), ("wA", wa), ("vB", vb), ("wB", wb)):
        for k in range(3):
            g.output(f"{name}_{'xyz'[k]}", v[k])
    assert [o.name for o in g.outputs] == CONTACT_OUT
    return g


# --- friction pass -----------------------------------------------------------------------------------
def friction_in(inertia_words: int = 3, manifold_friction: bool = False, tangents_on_chip: bool = False) -> list[str]:
    """The friction pipe's input words (``mu`` last where the manifold carries its coefficient; no t0, t1 where
    the pipe derives them from n)."""
    tangents = [] if tangents_on_chip else ["t0_x", "t0_y", "t0_z", "t1_x", "t1_y", "t1_z"]
    return (["n_x", "n_y", "n_z", "c_x", "c_y", "c_z"] + tangents + ["f_jac_inv0", "f_jac_inv1"] + [f"lam_n{i}" for i in range(4)] + ["lamT0", "lamT1"]
            + [f"{v}_{c}" for v in ("xA", "xB", "vA", "wA", "vB", "wB") for c in "xyz"]
            + ["mInvA", "mInvB"] + inertia_ports(inertia_words) + (["mu"] if manifold_friction else []))


def _inertia_doc(inertia_words: int, manifold_friction: bool = False) -> str:
    if inertia_words == 3 and not manifold_friction:
        return ""
    mode = _MODE_OF_WORDS[inertia_words].value
    return (f"\n\nInverse inertia: the {mode} mode ({inertia_words} words per body, models/setup/inertia.py)"
            + ("; the friction coefficient is the input word mu." if manifold_friction else "."))


FRICTION_IN = friction_in()
FRICTION_SIGN_BUG_DOC = """\
INJECTED BUG, for a test build only (generated into build/, never into rtl/): the velocity updates of both
tangent rows apply +delta instead of -delta (a wrong sign in the friction pass, for the co-simulation test that
expects the scoreboard to catch it)."""
FRICTION_OUT = ["lamT0", "lamT1"] + [f"{v}_{c}" for v in ("vA", "wA", "vB", "wB") for c in "xyz"]


def plane_space(g: Graph, n: Vec) -> tuple[Vec, Vec]:
    """The tangent basis of the normal n, ``models/setup/tangent_basis.py`` ``plane_space_in`` operation by
    operation."""
    m = [(-x).named(f"m_{'xyz'[k]}") for k, x in enumerate(n)]
    one, zero = g.const(1.0, "one"), g.const(0.0, "zero")
    use_z = g.lt(g.const(PLANE_SPACE_SPLIT, "split"), g.max(m[2], -m[2]), name="use_z")
    a_z = (m[1] * m[1] + m[2] * m[2]).named("a_z")
    k_z = (one / g.sqrt(g.select(use_z, a_z, one))).named("k_z")
    pz = [zero, ((-m[2]) * k_z).named("pz_y"), (m[1] * k_z).named("pz_z")]
    qz = [(a_z * k_z).named("qz_x"), ((-m[0]) * pz[2]).named("qz_y"), (m[0] * pz[1]).named("qz_z")]
    a_x = (m[0] * m[0] + m[1] * m[1]).named("a_x")
    k_x = (one / g.sqrt(g.select(use_z, one, a_x))).named("k_x")
    px = [((-m[1]) * k_x).named("px_x"), (m[0] * k_x).named("px_y"), zero]
    qx = [((-m[2]) * px[1]).named("qx_x"), (m[2] * px[0]).named("qx_y"), (a_x * k_x).named("qx_z")]
    return named(vselect(g, use_z, pz, px), "t0"), named(vselect(g, use_z, qz, qx), "t1")


def friction_graph(sign_bug: bool = False, inertia_words: int = 3, manifold_friction: bool = False,
                   tangents_on_chip: bool = False) -> Graph:
    """The friction pass; ``sign_bug``: the injected-bug variant of the co-simulation test (``+delta`` applied to
    the velocities in place of ``-delta``), the same module name and ports, for a test build only;
    ``tangents_on_chip``: t0, t1 derived from n (:func:`plane_space`, module ``pgs_friction_pipe_tb``)."""
    module = pipe_module("pgs_friction_pipe", inertia_words, manifold_friction) + ("_tb" if tangents_on_chip else "")
    mu_doc = "mu the input word" if manifold_friction else f"mu = {FRICTION_COEFF}"
    g = Graph(module, doc=f"""\
{module}: one friction pass of one manifold (models/golden/contact_solver.py friction_solve for
a single manifold; models/golden/OPERATION_ORDER.md "Friction pass"), {mu_doc}. A manifold with
f_jac_inv[0] == 0 is skipped (lamT and the velocities pass through unchanged: selects); otherwise
spin damping (factor {SPIN_DAMP_FACTOR}) is applied when in_spin_damp is set. The velocities of a static body are
computed the same way; the caller must not write them back.""" + _inertia_doc(inertia_words, manifold_friction)
              + ("\n\n" + FRICTION_SIGN_BUG_DOC if sign_bug else ""))
    n = g.inputs_vec("n")
    c = g.inputs_vec("c")
    t = [] if tangents_on_chip else [g.inputs_vec("t0"), g.inputs_vec("t1")]
    fji = [g.input("f_jac_inv0"), g.input("f_jac_inv1")]
    ln = [g.input(f"lam_n{i}") for i in range(4)]
    lam_t = [g.input("lamT0"), g.input("lamT1")]
    xa, xb = g.inputs_vec("xA"), g.inputs_vec("xB")
    va, wa = g.inputs_vec("vA"), g.inputs_vec("wA")
    vb, wb = g.inputs_vec("vB"), g.inputs_vec("wB")
    ma, mb = g.input("mInvA"), g.input("mInvB")
    ia, ib = inertia_inputs(g, "A", inertia_words), inertia_inputs(g, "B", inertia_words)
    mu = g.input("mu") if manifold_friction else g.const(FRICTION_COEFF, "mu")
    spin = g.bool_input("spin_damp")
    assert [v.name.removeprefix("in_") for v in g.inputs] == friction_in(inertia_words, manifold_friction,
                                                                          tangents_on_chip)
    if tangents_on_chip:
        with g.scope("basis"):
            t = list(plane_space(g, n))

    skip = g.is_zero(fji[0], name="skip")
    limit = (mu * ((ln[0] + ln[1]) + (ln[2] + ln[3]))).named("limit")
    neg_limit = (-limit).named("neg_limit")
    ra = named(vsub(c, xa), "rA")
    rb = named(vsub(c, xb), "rB")
    for j in range(2):
        with g.scope(f"t{j}"):
            tj = t[j]
            ca = named(cross3(ra, tj), "cA")
            cb = named(cross3(rb, tj), "cB")
            u = ((dot3(tj, va) - dot3(tj, vb)) + (dot3(ca, wa) - dot3(cb, wb))).named("u")
            delta = ((-u) * fji[j]).named("delta0")
            new = g.min(g.max(lam_t[j] + delta, neg_limit), limit, name="lam_new")
            delta = (new - lam_t[j]).named("delta")
            lam_t[j] = g.select(skip, lam_t[j], new, name="lamT")
            # e = -delta is the impulse change applied to both bodies' velocities (the injected bug: +delta)
            e = delta if sign_bug else (-delta).named("e")
            va = named(vselect(g, skip, va, vadd(va, scale3(named(scale3(tj, ma), "linA"), e))), "vA")
            wa = named(vselect(g, skip, wa, vadd(wa, scale3(named(inertia_mul(ia, ca), "angA"), e))), "wA")
            vb = named(vselect(g, skip, vb, vsub(vb, scale3(named(scale3(tj, mb), "linB"), e))), "vB")
            wb = named(vselect(g, skip, wb, vsub(wb, scale3(named(inertia_mul(ib, cb), "angB"), e))), "wB")
    with g.scope("spin"):
        k = g.const(SPIN_DAMP_FACTOR, "spin_damp")
        wa_d = named(vsub(wa, scale3(n, (dot3(n, wa) * k).named("sA"))), "wA_damped")
        wb_d = named(vsub(wb, scale3(n, (dot3(n, wb) * k).named("sB"))), "wB_damped")
        # damp = active & spin_damp; when skipped, wa / wb already hold the inputs
        wa = named(vselect(g, skip, wa, vselect(g, spin, wa_d, wa)), "wA")
        wb = named(vselect(g, skip, wb, vselect(g, spin, wb_d, wb)), "wB")
    g.output("lamT0", lam_t[0])
    g.output("lamT1", lam_t[1])
    for name, v in (("vA", va), ("wA", wa), ("vB", vb), ("wB", wb)):
        for kk in range(3):
            g.output(f"{name}_{'xyz'[kk]}", v[kk])
    assert [o.name for o in g.outputs] == FRICTION_OUT
    return g


# --- integration -------------------------------------------------------------------------------------
INTEGRATE_IN = ["pos_x", "pos_y", "pos_z", "q_x", "q_y", "q_z", "q_w", "v_x", "v_y", "v_z", "w_x", "w_y", "w_z",
                "dt", "damping", "g_x", "g_y", "g_z"]
INTEGRATE_OUT = ["pos_x", "pos_y", "pos_z", "q_x", "q_y", "q_z", "q_w", "v_x", "v_y", "v_z", "w_x", "w_y", "w_z"]


def _horner(g: Graph, x2: Value, coeffs: tuple[float, ...], name: str) -> Value:
    """c0 + x2*(c1 + x2*(c2 + ...)) (models.golden.integrator._horner)."""
    acc = g.const(coeffs[-1], f"{name}{len(coeffs) - 1}")
    for i in range(len(coeffs) - 2, -1, -1):
        acc = g.const(coeffs[i], f"{name}{i}") + x2 * acc
    return acc


def integrate_graph() -> Graph:
    g = Graph("pgs_integrate_pipe", doc=f"""\
pgs_integrate_pipe: integration of one body (models/golden/integrator.py integrate for a single dynamic
body; models/golden/OPERATION_ORDER.md "Integration"). The run constants half_dt = 0.5*dt,
dt3c = ((dt*dt)*dt)*{TAYLOR_SINC} and g_dt = g*dt are computed here from the dt / g inputs, as the
golden computes them. sin / cos are the golden's Taylor polynomials; the angle is clamped to
MAX_ANGLE / dt when theta*dt > MAX_ANGLE, and theta < {SMALL_ANGLE} selects the small-angle sinc.""")
    pos = g.inputs_vec("pos")
    q = g.inputs_vec("q", 4)
    v = g.inputs_vec("v")
    w_in = g.inputs_vec("w")
    dt = g.input("dt")
    damping = g.input("damping")
    grav = g.inputs_vec("g")
    assert [x.name.removeprefix("in_") for x in g.inputs] == INTEGRATE_IN

    half_dt = (g.const(0.5, "half") * dt).named("half_dt")
    dt3c = (((dt * dt) * dt) * g.const(TAYLOR_SINC, "taylor_sinc")).named("dt3c")
    g_dt = named([grav[k] * dt for k in range(3)], "g_dt")
    max_angle = g.const(MAX_ANGLE, "max_angle")

    w = named([w_in[k] * damping for k in range(3)], "w")
    theta0 = g.sqrt((w[0] * w[0] + w[1] * w[1]) + w[2] * w[2], name="theta0")
    clamp = g.lt(max_angle, theta0 * dt, name="clamp")              # theta*dt > MAX_ANGLE
    theta = g.select(clamp, (max_angle / dt).named("theta_max"), theta0, name="theta")
    x = (theta * half_dt).named("x")
    small = g.lt(theta, g.const(SMALL_ANGLE, "small_angle"), name="small")
    s_small = (half_dt - (dt3c * theta) * theta).named("s_small")
    x2 = (x * x).named("x2")
    sin_x = (x + x * (x2 * _horner(g, x2, SIN_COEFFS, "sin_c"))).named("sin_x")
    s_large = (sin_x / theta).named("s_large")
    s = g.select(small, s_small, s_large, name="s")
    cos_x = (g.const(1.0, "one") + x2 * _horner(g, x2, COS_COEFFS, "cos_c")).named("cos_x")
    dq = named([w[k] * s for k in range(3)], "dq") + [cos_x]
    # quat_mul(dq, q): a = dq, b = q
    ax, ay, az, aw = dq
    bx, by, bz, bw = q
    qn = [
        ((aw * bx + ax * bw) + (ay * bz - az * by)).named("qn_x"),
        ((aw * by + ay * bw) + (az * bx - ax * bz)).named("qn_y"),
        ((aw * bz + az * bw) + (ax * by - ay * bx)).named("qn_z"),
        ((aw * bw - ax * bx) - (ay * by + az * bz)).named("qn_w"),
    ]
    norm2 = ((qn[0] * qn[0] + qn[1] * qn[1]) + (qn[2] * qn[2] + qn[3] * qn[3])).named("norm2")
    inv_norm = (g.const(1.0, "one") / g.sqrt(norm2, name="norm")).named("inv_norm")
    q_out = [(qn[k] * inv_norm).named(f"q_{'xyzw'[k]}") for k in range(4)]
    pos_out = named(vadd(pos, [v[k] * dt for k in range(3)]), "pos")
    v_out = named(vadd(v, g_dt), "v")
    for k in range(3):
        g.output(f"pos_{'xyz'[k]}", pos_out[k])
    for k in range(4):
        g.output(f"q_{'xyzw'[k]}", q_out[k])
    for k in range(3):
        g.output(f"v_{'xyz'[k]}", v_out[k])
    for k in range(3):
        g.output(f"w_{'xyz'[k]}", w[k])
    assert [o.name for o in g.outputs] == INTEGRATE_OUT
    return g


GRAPHS = {
    "pgs_contact_pipe": contact_graph,
    "pgs_friction_pipe": friction_graph,
    "pgs_integrate_pipe": integrate_graph,
    # the friction pipe that derives the tangent basis from the normal (a record layout without t0, t1): its own
    # latency, instantiated by the kernel built with TANGENTS_ON_CHIP (models/setup/tangent_basis.py)
    "pgs_friction_pipe_tb": partial(friction_graph, tangents_on_chip=True),
}


# the contact and friction pipes of the other inverse-inertia modes (the kernel's IINV_W = 1 or 6), by module name;
# every mode has the default pipes' latencies (cocotb_tests/test_pipe_graph_modes.py), so they share the latency package
# (and the friction pipes taking the manifold's coefficient as a word, the kernel's MU_W = 1, in every mode)
MODE_GRAPHS: dict[str, Callable[[], Graph]] = {
    **{pipe_module("pgs_contact_pipe", w): partial(contact_graph, w) for w in (1, 6)},
    **{pipe_module("pgs_friction_pipe", w): partial(friction_graph, inertia_words=w) for w in (1, 6)},
    **{pipe_module("pgs_friction_pipe", w, True): partial(friction_graph, inertia_words=w, manifold_friction=True)
       for w in (1, 3, 6)},
    # the soft contact pipe (the kernel's SOFT_CONTACT = 1): the same latency (the lam * keep multiply is off the
    # critical path, cocotb_tests/test_soft_contact_pipe.py)
    "pgs_contact_pipe_soft": partial(contact_graph, soft=True),
}


# --- the shared datapath: one lane's contact and friction passes on one set of operators ------------------------------
SHARED_IMPULSE_OUT = [f"imp{i}" for i in range(4)]  # contact: lam0..3; friction: lamT0, lamT1, then two zero words
SHARED_OUT = SHARED_IMPULSE_OUT + CONTACT_OUT[4:]
SHARED_DOC = """\
{module}: one lane's contact pass ({contact}) and friction pass ({friction}) on one datapath
(rtl/gen/shared_datapath.py): the record's kind
(in_kind: 0 contact, 1 friction) travels down the pipe with it, the friction pass's operations run on the contact
pass's operators where one is free at their stage (an operand multiplexer selects by the kind where the two read
different words), and out_kind says which pass a result is of. Both kinds take LATENCY cycles.

Inputs: the contact record's words, or the friction record's from word 0 (its coefficient, with a word of its own,
after its tangents' Jacobians), then lam[4] (a friction pass's normal impulses), lamT[2] (friction only), the bodies'
words; outputs: imp0..3 (contact lam0..3; friction lamT0, lamT1, 0, 0), then vA, wA, vB, wB."""


def shared_module(inertia_words: int = 3, soft: bool = False, manifold_friction: bool = False,
                  tangents_on_chip: bool = False) -> str:
    """The shared datapath's module name: ``pgs_shared_pipe`` suffixed like the pipes it binds."""
    return (pipe_module("pgs_shared_pipe", inertia_words, manifold_friction)
            + ("_soft" if soft else "") + ("_tb" if tangents_on_chip else ""))


def shared_in(inertia_words: int = 3, soft: bool = False, manifold_friction: bool = False,
              tangents_on_chip: bool = False) -> tuple[list[str], list[int], list[int]]:
    """The shared datapath's input words and where each graph's input words go (contact's, friction's): the record
    words (a word the two name alike keeps the name, else ``<contact>__<friction>``), lam[4], lamT[2], the bodies,
    the soft pipe's keep factors."""
    c_names = contact_in(inertia_words, soft)
    f_names = friction_in(inertia_words, manifold_friction, tangents_on_chip)
    c_rec, f_rec = c_names.index("lam0"), f_names.index("lam_n0")
    f_record = f_names[:f_rec] + (["mu"] if manifold_friction else [])
    bodies = f_names[f_rec + 6:len(f_names) - (1 if manifold_friction else 0)]
    assert bodies == c_names[c_rec + 4:c_rec + 4 + len(bodies)] and len(f_record) <= c_rec
    words = [c if k >= len(f_record) or f_record[k] == c else f"{c}__{f_record[k]}"
             for k, c in enumerate(c_names[:c_rec])]
    words += [f"lam{i}" for i in range(4)] + ["lamT0", "lamT1"] + c_names[c_rec + 4:]
    c_slot = [k if k < c_rec + 4 else k + 2 for k in range(len(c_names))]
    at = {name: k for k, name in enumerate(words)}
    f_slot = []
    for k, name in enumerate(f_names):
        if k < f_rec:
            f_slot.append(k)
        elif name == "mu":
            f_slot.append(f_rec)
        elif name.startswith("lam_n"):
            f_slot.append(c_rec + int(name[-1]))
        else:
            f_slot.append(at[name])
    return words, c_slot, f_slot


def shared_graph(inertia_words: int = 3, soft: bool = False, manifold_friction: bool = False,
                 tangents_on_chip: bool = False, sign_bug: bool = False) -> SharedDatapath:
    """The shared datapath of the contact and friction pipes of these options (:mod:`rtl.gen.shared_datapath`);
    ``sign_bug``: with the injected-bug friction pass (:func:`friction_graph`), for a test build only."""
    contact = contact_graph(inertia_words, soft)
    friction = friction_graph(sign_bug, inertia_words=inertia_words, manifold_friction=manifold_friction,
                              tangents_on_chip=tangents_on_chip)
    words, c_slot, f_slot = shared_in(inertia_words, soft, manifold_friction, tangents_on_chip)
    c_out = list(range(len(CONTACT_OUT)))
    f_out = [0, 1, None, None] + list(range(2, len(FRICTION_OUT)))
    layout = SharedLayout(tuple(words), (tuple(c_slot), tuple(f_slot)), tuple(SHARED_OUT), (tuple(c_out), tuple(f_out)))
    module = shared_module(inertia_words, soft, manifold_friction, tangents_on_chip)
    doc = (SHARED_DOC.format(module=module, contact=contact.name, friction=friction.name)
           + ("\n\n" + FRICTION_SIGN_BUG_DOC if sign_bug else ""))
    return SharedDatapath(module, doc, (contact, friction), layout)


# the shared datapaths of every lane the kernel builds (its IINV_W, MU_W, SOFT_CONTACT and TANGENTS_ON_CHIP), by module
# name; every one has the contact pipe's latency (the friction pass is bound within it: rtl/gen/shared_datapath.py)
SHARED_GRAPHS: dict[str, Callable[[], SharedDatapath]] = {
    shared_module(w, soft, mu, tb): partial(shared_graph, w, soft, mu, tb)
    for w, soft, mu, tb in [(w, False, mu, False) for w in (1, 3, 6) for mu in (False, True)]
    + [(3, True, mu, False) for mu in (False, True)] + [(3, soft, False, True) for soft in (False, True)]}
