// pgs_solver.h: the arithmetic of one manifold-pass and of one body's integration, operation for operation in
// the golden order of models/golden/OPERATION_ORDER.md (models/golden/contact_solver.py contact_solve / friction_solve,
// models/golden/integrator.py integrate). Every operation goes through pgs_fp.h (rounded once, flush to zero).
// Branches on data are selects (the thesis's "branchless" form): every point and tangent row is computed,
// and an inactive one keeps the previous impulse and velocities.
#ifndef PGS_SOLVER_H
#define PGS_SOLVER_H

#include "pgs_fp.h"
#include "pgs_stream.h"

namespace pgs {

// constants of the datapath (rounded once to binary32 from these double values, as the golden's ar.const)
constexpr double kFrictionCoeff = 0.7;   // models.setup.constraints.FRICTION_COEFF (Bullet's hard-coded mu)
constexpr double kSpinDampFactor = 0.1;  // models.golden.contact_solver.SPIN_DAMP_FACTOR
constexpr double kMaxAngle = 0.25 * 3.14159254;  // models.golden.integrator.MAX_ANGLE (Bullet's value, sic)
constexpr double kSmallAngle = 0.001;
constexpr double kTaylorSinc = 0.020833333333;
constexpr double kSinCoeffs[3] = {-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0};
constexpr double kCosCoeffs[4] = {-1.0 / 2.0, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0};

// Per body, read-only during the passes; a record's as it gathers them (a shock pass's row: the frozen body's inverse
// mass and inertia +0, a linear row's inverse inertia +0; pgs_kernel.cpp shock_row).
struct BodyRef {
    Vec3 x;
    float m_inv;
    InvInertia i_inv;
};

// The soft contact row's per-call constants (models/golden/soft_contact.py, SolverParams.soft_keep): with `on`, each point's
// accumulated impulse is multiplied by its keep factor before the add (1 where b > 0, `stat` for a row with a static
// body, `dyn` otherwise); off: the rigid row (a build with PGS_SOFT_CONTACT = 0 never multiplies).
struct SoftKeep {
    bool on;
    float dyn, stat;
};
#ifndef PGS_SOFT_CONTACT
#define PGS_SOFT_CONTACT 0
#endif
constexpr bool kSoftContact = PGS_SOFT_CONTACT != 0;

// Per body, read and written by the passes.
struct Velocity {
    Vec3 v, w;
};

// --- vectors --------------------------------------------------------------------------------------------
inline Vec3 vec3(float x, float y, float z) {
    Vec3 v = {x, y, z};
    return v;
}
inline Vec3 v_add(const Vec3& a, const Vec3& b) { return vec3(add(a.x, b.x), add(a.y, b.y), add(a.z, b.z)); }
inline Vec3 v_sub(const Vec3& a, const Vec3& b) { return vec3(sub(a.x, b.x), sub(a.y, b.y), sub(a.z, b.z)); }
inline Vec3 v_scale(const Vec3& v, float s) { return vec3(mul(v.x, s), mul(v.y, s), mul(v.z, s)); }

// I^-1 c in models.setup.inertia.inertia_product's order: one multiply per component for the scalar and the diagonal,
// ((Ixx cx + Ixy cy) + Ixz cz, (Ixy cx + Iyy cy) + Iyz cz, (Ixz cx + Iyz cy) + Izz cz) for the symmetric 3x3
template <int WORDS>
inline Vec3 inertia_mul_words(const float (&i)[WORDS], const Vec3& c);
template <>
inline Vec3 inertia_mul_words<1>(const float (&i)[1], const Vec3& c) {
    return vec3(mul(i[0], c.x), mul(i[0], c.y), mul(i[0], c.z));
}
template <>
inline Vec3 inertia_mul_words<3>(const float (&i)[3], const Vec3& c) {
    return vec3(mul(i[0], c.x), mul(i[1], c.y), mul(i[2], c.z));
}
template <>
inline Vec3 inertia_mul_words<6>(const float (&i)[6], const Vec3& c) {
    const float xx = i[0], yy = i[1], zz = i[2], xy = i[3], xz = i[4], yz = i[5];
    return vec3(add(add(mul(xx, c.x), mul(xy, c.y)), mul(xz, c.z)), add(add(mul(xy, c.x), mul(yy, c.y)), mul(yz, c.z)),
                add(add(mul(xz, c.x), mul(yz, c.y)), mul(zz, c.z)));
}
inline Vec3 inertia_mul(const InvInertia& i, const Vec3& c) { return inertia_mul_words<kIInvWords>(i.k, c); }

// (a.x*b.x + a.y*b.y) + a.z*b.z
inline float dot3(const Vec3& a, const Vec3& b) { return add(add(mul(a.x, b.x), mul(a.y, b.y)), mul(a.z, b.z)); }

// (a.y*b.z - a.z*b.y, a.z*b.x - a.x*b.z, a.x*b.y - a.y*b.x)
inline Vec3 cross3(const Vec3& a, const Vec3& b) {
    return vec3(sub(mul(a.y, b.z), mul(a.z, b.y)), sub(mul(a.z, b.x), mul(a.x, b.z)), sub(mul(a.x, b.y), mul(a.y, b.x)));
}

// vA += lin_a*d, wA += ang_a*d, vB -= lin_b*d, wB -= ang_b*d; kept only when `active`
inline void apply_impulse(Velocity& a, Velocity& b, const Vec3& lin_a, const Vec3& ang_a, const Vec3& lin_b,
                          const Vec3& ang_b, float d, bool active) {
    const Velocity na = {v_add(a.v, v_scale(lin_a, d)), v_add(a.w, v_scale(ang_a, d))};
    const Velocity nb = {v_sub(b.v, v_scale(lin_b, d)), v_sub(b.w, v_scale(ang_b, d))};
    if (active) {
        a = na;
        b = nb;
    }
}

// --- contact pass of one manifold: lam[0..3] in/out ---------------------------------------------------------
inline void solve_contact(const ContactRec& r, const BodyRef& A, const BodyRef& B, Velocity& va, Velocity& vb,
                          float lam[4], const SoftKeep& soft) {
    const Vec3 lin_a = v_scale(r.n, A.m_inv);
    const Vec3 lin_b = v_scale(r.n, B.m_inv);
    const float keep_row = (A.m_inv == 0.0f || B.m_inv == 0.0f) ? soft.stat : soft.dyn;
POINTS:
    for (int i = 0; i < 4; i++) {  // sequential: point i+1 sees point i's velocities
#pragma HLS UNROLL
        const bool active = r.jac_inv[i] != 0.0f;
        const Vec3 ca = cross3(v_sub(r.p[i], A.x), r.n);
        const Vec3 cb = cross3(v_sub(r.p[i], B.x), r.n);
        const float vrel = add(sub(dot3(r.n, va.v), dot3(r.n, vb.v)), sub(dot3(ca, va.w), dot3(cb, vb.w)));
        const float d0 = mul(add(vrel, r.bias[i]), r.jac_inv[i]);
        const float start = (kSoftContact && soft.on) ? mul(lam[i], r.bias[i] > 0.0f ? 1.0f : keep_row) : lam[i];
        const float lam_new = maximum(add(start, d0), 0.0f);
        const float d = sub(lam_new, lam[i]);
        if (active) lam[i] = lam_new;
        apply_impulse(va, vb, lin_a, inertia_mul(A.i_inv, ca), lin_b, inertia_mul(B.i_inv, cb), d, active);
    }
}

// --- the friction tangent basis derived from the normal (PGS_TANGENTS_ON_CHIP = 1) ------------------------------
// models/setup/tangent_basis.py plane_space_in, operation for operation (the RTL's pgs_friction_pipe_tb, rtl/gen
// kernel_graphs.py plane_space): Bullet's btPlaneSpace1 of m = -n, every operation rounded to the format, the
// square root and the division each once; the branch on |m_z| is a select (both bases are computed).
constexpr double kPlaneSpaceSplit = 0.70710678;  // models.setup.tangent_basis.PLANE_SPACE_SPLIT (Bullet's SIMDSQRT12)

inline void plane_space(const Vec3& n, Vec3 t[2]) {
    const float mx = -n.x, my = -n.y, mz = -n.z;  // sign flips: exact
    const float one = constant(1.0), zero = 0.0f;
    const bool use_z = constant(kPlaneSpaceSplit) < maximum(mz, -mz);
    const float a_z = add(mul(my, my), mul(mz, mz));
    const float k_z = div(one, sqrt(use_z ? a_z : one));
    const Vec3 pz = vec3(zero, mul(-mz, k_z), mul(my, k_z));
    const Vec3 qz = vec3(mul(a_z, k_z), mul(-mx, pz.z), mul(mx, pz.y));
    const float a_x = add(mul(mx, mx), mul(my, my));
    const float k_x = div(one, sqrt(use_z ? one : a_x));
    const Vec3 px = vec3(mul(-my, k_x), mul(mx, k_x), zero);
    const Vec3 qx = vec3(mul(-mz, px.y), mul(mz, px.x), mul(a_x, k_x));
    t[0] = use_z ? pz : px;
    t[1] = use_z ? qz : qx;
}

// --- friction pass of one manifold: lam_t[0..1] in/out, lam_n the manifold's normal impulses ----------------
inline void solve_friction(const FrictionRec& r, const BodyRef& A, const BodyRef& B, Velocity& va, Velocity& vb,
                           const float lam_n[4], float lam_t[2]) {
    const bool active = r.f_jac_inv[0] != 0.0f;  // Bullet's early return
    const float mu = kMuWords ? r.mu : constant(kFrictionCoeff);
    const float limit = mul(mu, add(add(lam_n[0], lam_n[1]), add(lam_n[2], lam_n[3])));
    const float neg_limit = -limit;
    const Vec3 ra = v_sub(r.c, A.x);
    const Vec3 rb = v_sub(r.c, B.x);
ROWS:
    for (int j = 0; j < 2; j++) {
#pragma HLS UNROLL
        const Vec3& t = r.t[j];
        const Vec3 ca = cross3(ra, t);
        const Vec3 cb = cross3(rb, t);
        const float u = add(sub(dot3(t, va.v), dot3(t, vb.v)), sub(dot3(ca, va.w), dot3(cb, vb.w)));
        const float d0 = mul(-u, r.f_jac_inv[j]);
        const float lam_new = minimum(maximum(add(lam_t[j], d0), neg_limit), limit);
        const float d = sub(lam_new, lam_t[j]);
        if (active) lam_t[j] = lam_new;
        // the friction impulse acts along -t on A and +t on B
        apply_impulse(va, vb, v_scale(t, A.m_inv), inertia_mul(A.i_inv, ca), v_scale(t, B.m_inv),
                      inertia_mul(B.i_inv, cb), -d, active);
    }
    const float k = constant(kSpinDampFactor);
    const Vec3 wa = v_sub(va.w, v_scale(r.n, mul(dot3(r.n, va.w), k)));
    const Vec3 wb = v_sub(vb.w, v_scale(r.n, mul(dot3(r.n, vb.w), k)));
    if (active && r.h.spin_damp && !r.h.shock_linear) {  // a linear shock row: no spin damping
        va.w = wa;
        vb.w = wb;
    }
}

// --- integration ------------------------------------------------------------------------------------------
// Run constants, computed once per step in the format.
struct IntegConsts {
    float dt, half_dt, dt3c, damping, max_angle;
    Vec3 g_dt;
};

inline IntegConsts integ_consts(float dt, const Vec3& gravity, float damping) {
    IntegConsts k;
    k.dt = dt;
    k.half_dt = mul(constant(0.5), dt);
    k.dt3c = mul(mul(mul(dt, dt), dt), constant(kTaylorSinc));
    k.g_dt = v_scale(gravity, dt);
    k.damping = damping;
    k.max_angle = constant(kMaxAngle);
    return k;
}

// c0 + x2*(c1 + x2*(c2 + ...)), the coefficients rounded to the format
template <int N>
float horner(float x2, const double (&coeffs)[N]) {
    float acc = constant(coeffs[N - 1]);
    for (int i = N - 2; i >= 0; i--) {
#pragma HLS UNROLL
        acc = add(constant(coeffs[i]), mul(x2, acc));
    }
    return acc;
}

inline float sin_poly(float x) {
    const float x2 = mul(x, x);
    return add(x, mul(x, mul(x2, horner(x2, kSinCoeffs))));
}

inline float cos_poly(float x) {
    const float x2 = mul(x, x);
    return add(constant(1.0), mul(x2, horner(x2, kCosCoeffs)));
}

// Hamilton product a (x) b of quaternions (x, y, z, w): Bullet's b3QuatMul
inline void quat_mul(const float a[4], const float b[4], float out[4]) {
    const float ax = a[0], ay = a[1], az = a[2], aw = a[3];
    const float bx = b[0], by = b[1], bz = b[2], bw = b[3];
    out[0] = add(add(mul(aw, bx), mul(ax, bw)), sub(mul(ay, bz), mul(az, by)));
    out[1] = add(add(mul(aw, by), mul(ay, bw)), sub(mul(az, bx), mul(ax, bz)));
    out[2] = add(add(mul(aw, bz), mul(az, bw)), sub(mul(ax, by), mul(ay, bx)));
    out[3] = sub(sub(mul(aw, bw), mul(ax, bx)), add(mul(ay, by), mul(az, bz)));
}

// One dynamic body after the passes: damping, orientation update, position and gravity.
inline BodyState integrate_body(const BodyState& b, const IntegConsts& k) {
    BodyState o = b;
    const Vec3 w = v_scale(b.w, k.damping);
    float theta = sqrt(add(add(mul(w.x, w.x), mul(w.y, w.y)), mul(w.z, w.z)));
    if (mul(theta, k.dt) > k.max_angle) theta = div(k.max_angle, k.dt);
    const float x = mul(theta, k.half_dt);
    const float s_small = sub(k.half_dt, mul(mul(k.dt3c, theta), theta));
    const float s_large = div(sin_poly(x), theta);
    const float s = theta < constant(kSmallAngle) ? s_small : s_large;
    const float dq[4] = {mul(w.x, s), mul(w.y, s), mul(w.z, s), cos_poly(x)};
    float q[4];
    quat_mul(dq, b.q, q);
    const float norm2 = add(add(mul(q[0], q[0]), mul(q[1], q[1])), add(mul(q[2], q[2]), mul(q[3], q[3])));
    const float inv_norm = div(constant(1.0), sqrt(norm2));
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        o.q[i] = mul(q[i], inv_norm);
    }
    o.w = w;
    o.pos = v_add(b.pos, v_scale(b.v, k.dt));
    o.v = v_add(b.v, k.g_dt);
    return o;
}

}  // namespace pgs

#endif  // PGS_SOLVER_H
