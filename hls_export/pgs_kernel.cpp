// pgs_kernel.cpp: the PGS kernel as Vitis HLS C++, with the structure of the 2018 thesis (a single function
// holding the Projected Gauss-Seidel contact and friction solvers and the integration):
//
//   * AXI4-Stream arguments (s_axis_body, s_axis_cons in, m_axis_body out, with TLAST; trace out) in the record
//     layouts of models/stream_format.py (pgs_stream.h), and an s_axilite bundle `control` with the register
//     map of rtl/README.md;
//   * the body table and the accumulated impulses in on-chip arrays (BRAM): the body-in records are streamed
//     in once, each pass streams one constraint record per manifold, the integration streams the bodies out;
//     built with PGS_IMPULSES_IN_RECORDS = 1 (the RTL's IMPULSES_IN_RECORDS, the design that fits the ZCU102) there
//     is no impulse array: each record carries the impulses its pass starts from and the updated ones leave on
//     m_axis_imp, one record per slot and pass (the DMA writes them to the DDR buffer the next passes read); with
//     PGS_TANGENTS_ON_CHIP = 1 as well (the RTL's TANGENTS_ON_CHIP) the friction records carry no t0, t1 and the
//     friction pass derives them from n (pgs_solver.h plane_space, models/tangent_basis.py);
//   * one pipelined loop per pass kind (PIPELINE, the fixed-size inner loops unrolled), ARRAY_PARTITION of the
//     per-body and per-slot words so that a record reads and writes all of them at once, and DEPENDENCE
//     inter false on the body velocities and the impulses (below).
//
// DEPENDENCE: within a pass every impulse slot is read and written by one record only, so the false
// dependence on imp_n / imp_t is exact. The velocities are not: a manifold reads the velocities of its
// bodies, which a manifold still in the pipeline may be about to write. Like the thesis (and the GPU code) the
// kernel declares that dependence false; the results equal the sequential (golden) order only when no two
// manifolds within the pipeline's depth share a dynamic body, which the host's hazard schedule
// (models/schedule.py, window >= records in flight) guarantees. The RTL kernel's hazard CAM, which makes any
// order exact, has no counterpart here. Passes do not overlap: each pass loop drains before the next starts.
// C simulation is sequential and therefore exact for every order; its testbench counts the records that
// would read a velocity still in flight (hls_export/README.md).
//
// Arithmetic: pgs_fp.h (golden rounding rules); operation order: pgs_solver.h.
#include "pgs_kernel.h"

#include "pgs_solver.h"

using namespace pgs;

namespace {

struct Errors {
    uint32_t flags;
    uint32_t first;
    void raise(uint32_t code) {
        if (flags == 0) first = code;
        flags |= 1u << (code - 1);
    }
    uint32_t status() const { return flags | (first << 8); }
};

// body_ref[i]: x(3), m_inv, i_inv(kIInvWords) (read-only while solving); body_vel[i]: v(3), w(3); body_q[i]: q(4)
constexpr int kRefWords = 4 + kIInvWords;
BodyRef load_ref(const float body_ref[kMaxBodies][kRefWords], uint32_t i) {
    BodyRef r;
    r.x = vec3(body_ref[i][0], body_ref[i][1], body_ref[i][2]);
    r.m_inv = body_ref[i][3];
    for (int k = 0; k < kIInvWords; k++) r.i_inv.k[k] = body_ref[i][4 + k];
    return r;
}

Velocity load_vel(const float body_vel[kMaxBodies][6], uint32_t i) {
    Velocity v;
    v.v = vec3(body_vel[i][0], body_vel[i][1], body_vel[i][2]);
    v.w = vec3(body_vel[i][3], body_vel[i][4], body_vel[i][5]);
    return v;
}

void store_vel(float body_vel[kMaxBodies][6], uint32_t i, const Velocity& v) {
    body_vel[i][0] = v.v.x;
    body_vel[i][1] = v.v.y;
    body_vel[i][2] = v.v.z;
    body_vel[i][3] = v.w.x;
    body_vel[i][4] = v.w.y;
    body_vel[i][5] = v.w.z;
}

// One constraint record; a TLAST that is not exactly on the last beat of the pass is error 1.
template <int BEATS>
ap_uint<BEATS * kConsW> read_cons(hls::stream<cons_beat_t>& s_axis_cons, bool last_of_pass, Errors& err) {
    bool bad_last = false;
    const ap_uint<BEATS * kConsW> rec = read_record<BEATS, kConsW>(s_axis_cons, last_of_pass, bad_last);
    if (bad_last) err.raise(kErrConsTlast);
    return rec;
}

// The two bodies of a record as the solver sees them: indices (modulo the table size, as the RTL; an index >=
// num_bodies is an error), constants and velocities.
struct BodyPair {
    uint32_t a, b;
    BodyRef A, B;
    Velocity va, vb;
};

// A body's constants as a shock pass's row takes them (the header bits; models/contact_solver.py _Gathered.freeze):
// a frozen body's inverse mass and inertia +0 (a static body for this record: its velocities are read, not written
// back), a linear row's inverse inertia +0.
BodyRef shock_row(const BodyRef& r, bool frozen, bool linear) {
    BodyRef s = r;
    s.m_inv = frozen ? 0.0f : r.m_inv;
    for (int k = 0; k < kIInvWords; k++) s.i_inv.k[k] = frozen || linear ? 0.0f : r.i_inv.k[k];
    return s;
}

BodyPair gather(const Header& h, uint32_t num_bodies, const float body_ref[kMaxBodies][kRefWords],
                const float body_vel[kMaxBodies][6], Errors& err) {
    if (h.body_a >= num_bodies || h.body_b >= num_bodies) err.raise(kErrBodyIndex);
    BodyPair p;
    p.a = h.body_a & (kMaxBodies - 1);
    p.b = h.body_b & (kMaxBodies - 1);
    p.A = shock_row(load_ref(body_ref, p.a), h.frozen_a, h.shock_linear);
    p.B = shock_row(load_ref(body_ref, p.b), h.frozen_b, h.shock_linear);
    p.va = load_vel(body_vel, p.a);
    p.vb = load_vel(body_vel, p.b);
    return p;
}

// Only dynamic bodies (m_inv != 0 as gathered) are written back; a static body's velocities are read-only, and so
// are a frozen body's in a shock pass's row.
void retire(float body_vel[kMaxBodies][6], const BodyPair& p) {
    if (p.A.m_inv != 0.0f) store_vel(body_vel, p.a, p.va);
    if (p.B.m_inv != 0.0f) store_vel(body_vel, p.b, p.vb);
}

void load_bodies(hls::stream<body_in_beat_t>& s_axis_body, uint32_t num_bodies, float body_ref[kMaxBodies][kRefWords],
                 float body_vel[kMaxBodies][6], float body_q[kMaxBodies][4], Errors& err) {
LOAD:
    for (uint32_t i = 0; i < num_bodies; i++) {
#pragma HLS PIPELINE II=1
#pragma HLS LOOP_TRIPCOUNT min=1 max=65536 avg=38880
        bool bad_last = false;
        const BodyState b = decode_body_in(read_record<kBodyInBeats, kBodyInW>(s_axis_body, i == num_bodies - 1,
                                                                               bad_last));
        if (bad_last) err.raise(kErrBodyTlast);
        body_ref[i][0] = b.pos.x;
        body_ref[i][1] = b.pos.y;
        body_ref[i][2] = b.pos.z;
        body_ref[i][3] = b.inv_mass;
        for (int k = 0; k < kIInvWords; k++) body_ref[i][4 + k] = b.inv_inertia.k[k];
        Velocity v;
        v.v = b.v;
        v.w = b.w;
        store_vel(body_vel, i, v);
        for (int c = 0; c < 4; c++) body_q[i][c] = b.q[c];
    }
}

// The impulses of the passes: on chip (imp_n, imp_t: one entry per slot) or, with PGS_IMPULSES_IN_RECORDS = 1, in
// the records (each carries the impulses its pass starts from) and out on m_axis_imp (one record per slot and pass,
// TLAST on the pass's last), which the DMA writes to the DDR impulse buffer the next passes' records are read with.
#if PGS_IMPULSES_IN_RECORDS
#define PGS_IMPULSE_ARGS hls::stream<imp_beat_t>& m_axis_imp
#define PGS_IMPULSE_CALL m_axis_imp
void write_impulses(hls::stream<imp_beat_t>& m_axis_imp, const float impulses[4], bool last_of_pass) {
    write_record<1, kImpOutW>(m_axis_imp, encode_impulse_out(impulses), last_of_pass);
}
#else
#define PGS_IMPULSE_ARGS float imp_n[kMaxManifolds][4], float imp_t[kMaxManifolds][2]
#define PGS_IMPULSE_CALL imp_n, imp_t
#endif

// One contact pass: record k of the pass is manifold slot k.
void contact_pass(hls::stream<cons_beat_t>& s_axis_cons, hls::stream<trace_t>& trace, uint32_t num_bodies,
                  uint32_t num_manifolds, uint32_t iteration, const float body_ref[kMaxBodies][kRefWords],
                  float body_vel[kMaxBodies][6], PGS_IMPULSE_ARGS, const SoftKeep& soft, Errors& err) {
    const bool zero_lam = iteration == 0;  // on chip: the impulses start the step at +0
    (void)zero_lam;
#if !PGS_IMPULSES_IN_RECORDS
    (void)imp_t;  // a contact pass touches the normal impulses only
#endif
CONTACT:
    for (uint32_t k = 0; k < num_manifolds; k++) {
#pragma HLS PIPELINE II=1
#pragma HLS LOOP_TRIPCOUNT min=1 max=262144 avg=127000
#pragma HLS DEPENDENCE variable=body_vel type=inter dependent=false
#if !PGS_IMPULSES_IN_RECORDS
#pragma HLS DEPENDENCE variable=imp_n type=inter dependent=false
#endif
        const ContactRec r = decode_contact(read_cons<kContactBeats>(s_axis_cons, k == num_manifolds - 1, err));
        BodyPair p = gather(r.h, num_bodies, body_ref, body_vel, err);
        float lam[4];
#if PGS_IMPULSES_IN_RECORDS
        for (int i = 0; i < 4; i++) lam[i] = r.lam[i];
#else
        for (int i = 0; i < 4; i++) lam[i] = zero_lam ? 0.0f : imp_n[k][i];
#endif
        solve_contact(r, p.A, p.B, p.va, p.vb, lam, soft);
#if PGS_IMPULSES_IN_RECORDS
        write_impulses(m_axis_imp, lam, k == num_manifolds - 1);
#else
        for (int i = 0; i < 4; i++) imp_n[k][i] = lam[i];
#endif
        retire(body_vel, p);
        trace.write(encode_trace(lam, p.va.v, p.va.w, p.vb.v, p.vb.w, k, iteration, false));
    }
}

// One friction pass (reads the manifold's normal impulses of the contact passes so far: on chip, or in the record).
void friction_pass(hls::stream<cons_beat_t>& s_axis_cons, hls::stream<trace_t>& trace, uint32_t num_bodies,
                   uint32_t num_manifolds, uint32_t iteration, const float body_ref[kMaxBodies][kRefWords],
                   float body_vel[kMaxBodies][6], PGS_IMPULSE_ARGS, Errors& err) {
    const bool zero_lam = iteration == 0;
    (void)zero_lam;
FRICTION:
    for (uint32_t k = 0; k < num_manifolds; k++) {
#pragma HLS PIPELINE II=1
#pragma HLS LOOP_TRIPCOUNT min=1 max=262144 avg=127000
#pragma HLS DEPENDENCE variable=body_vel type=inter dependent=false
#if !PGS_IMPULSES_IN_RECORDS
#pragma HLS DEPENDENCE variable=imp_t type=inter dependent=false
#endif
        FrictionRec r = decode_friction(read_cons<kFrictionBeats>(s_axis_cons, k == num_manifolds - 1, err));
        if (kTangentsOnChip) plane_space(r.n, r.t);  // the record carries no t0, t1: derived from n
        BodyPair p = gather(r.h, num_bodies, body_ref, body_vel, err);
        float lam_n[4], lam_t[2];
#if PGS_IMPULSES_IN_RECORDS
        for (int i = 0; i < 4; i++) lam_n[i] = r.lam[i];
        for (int j = 0; j < 2; j++) lam_t[j] = r.lam_t[j];
#else
        for (int i = 0; i < 4; i++) lam_n[i] = imp_n[k][i];
        for (int j = 0; j < 2; j++) lam_t[j] = zero_lam ? 0.0f : imp_t[k][j];
#endif
        solve_friction(r, p.A, p.B, p.va, p.vb, lam_n, lam_t);
        const float impulses[4] = {lam_t[0], lam_t[1], 0.0f, 0.0f};
#if PGS_IMPULSES_IN_RECORDS
        write_impulses(m_axis_imp, impulses, k == num_manifolds - 1);
#else
        for (int j = 0; j < 2; j++) imp_t[k][j] = lam_t[j];
#endif
        retire(body_vel, p);
        trace.write(encode_trace(impulses, p.va.v, p.va.w, p.vb.v, p.vb.w, k, iteration, true));
    }
}

// Every body in index order: dynamic bodies integrated, static ones unchanged, out as body-out records.
void integrate_out(hls::stream<body_out_beat_t>& m_axis_body, uint32_t num_bodies, const IntegConsts& kc,
                   const float body_ref[kMaxBodies][kRefWords], const float body_vel[kMaxBodies][6],
                   const float body_q[kMaxBodies][4]) {
INTEGRATE:
    for (uint32_t i = 0; i < num_bodies; i++) {
#pragma HLS PIPELINE II=1
#pragma HLS LOOP_TRIPCOUNT min=1 max=65536 avg=38880
        BodyState b;
        const BodyRef r = load_ref(body_ref, i);
        const Velocity v = load_vel(body_vel, i);
        b.pos = r.x;
        b.inv_mass = r.m_inv;
        b.inv_inertia = r.i_inv;
        b.v = v.v;
        b.w = v.w;
        for (int c = 0; c < 4; c++) b.q[c] = body_q[i][c];
        const BodyState out = b.inv_mass != 0.0f ? integrate_body(b, kc) : b;
        write_record<kBodyOutBeats, kBodyOutW>(m_axis_body, encode_body_out(out), i == num_bodies - 1);
    }
}

}  // namespace

void pgs_kernel(hls::stream<body_in_beat_t>& s_axis_body, hls::stream<cons_beat_t>& s_axis_cons,
                hls::stream<body_out_beat_t>& m_axis_body, hls::stream<trace_t>& trace, PGS_IMP_OUT_PORT
                uint32_t num_bodies, uint32_t num_manifolds, uint32_t iterations, uint32_t dt, uint32_t gravity_x,
                uint32_t gravity_y, uint32_t gravity_z, uint32_t damping, uint32_t options, PGS_SOFT_PORTS
                uint32_t* status, uint32_t* issued) {
#pragma HLS INTERFACE mode=axis port=s_axis_body
#pragma HLS INTERFACE mode=axis port=s_axis_cons
#pragma HLS INTERFACE mode=axis port=m_axis_body
#pragma HLS INTERFACE mode=axis port=trace
#if PGS_IMPULSES_IN_RECORDS
#pragma HLS INTERFACE mode=axis port=m_axis_imp
#endif
    // the argument offsets of models/register_map.py (generated/pgs_regs.h: PGS_PRAGMA expands PGS_REG_*)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=num_bodies bundle=control offset=PGS_REG_NUM_BODIES)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=num_manifolds bundle=control offset=PGS_REG_NUM_MANIFOLDS)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=iterations bundle=control offset=PGS_REG_ITERATIONS)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=dt bundle=control offset=PGS_REG_DT)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=gravity_x bundle=control offset=PGS_REG_GRAVITY_X)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=gravity_y bundle=control offset=PGS_REG_GRAVITY_Y)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=gravity_z bundle=control offset=PGS_REG_GRAVITY_Z)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=damping bundle=control offset=PGS_REG_DAMPING)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=options bundle=control offset=PGS_REG_OPTIONS)
#if PGS_SOFT_CONTACT
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=keep_dyn bundle=control offset=PGS_REG_KEEP_DYN)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=keep_static bundle=control offset=PGS_REG_KEEP_STATIC)
#endif
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=status bundle=control offset=PGS_REG_STATUS)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=issued bundle=control offset=PGS_REG_ISSUED)
#pragma HLS INTERFACE mode=s_axilite port=return bundle=control

    // On-chip memories (BRAM). Each per-body / per-slot word is its own array (ARRAY_PARTITION of dim 2), so a
    // record reads or writes all words of a body in one access of each array.
    static float body_ref[kMaxBodies][kRefWords];
    static float body_vel[kMaxBodies][6];
    static float body_q[kMaxBodies][4];
#pragma HLS ARRAY_PARTITION variable=body_ref type=complete dim=2
#pragma HLS ARRAY_PARTITION variable=body_vel type=complete dim=2
#pragma HLS ARRAY_PARTITION variable=body_q type=complete dim=2
#if !PGS_IMPULSES_IN_RECORDS  // else no impulse array: the impulses travel with the records
    static float imp_n[kMaxManifolds][4];
    static float imp_t[kMaxManifolds][2];
#pragma HLS ARRAY_PARTITION variable=imp_n type=complete dim=2
#pragma HLS ARRAY_PARTITION variable=imp_t type=complete dim=2
#endif
#pragma HLS BIND_STORAGE variable=body_vel type=ram_t2p impl=bram
#pragma HLS BIND_STORAGE variable=body_ref type=ram_t2p impl=bram

    Errors err = {0, 0};
    uint32_t count = 0;
    if (num_bodies > kMaxBodies || num_manifolds > kMaxManifolds || iterations > kMaxIterations) {
        err.raise(kErrBadArgs);  // the step ends at once, streams untouched
    } else if (num_bodies != 0) {  // no bodies: nothing to load, solve or integrate (as the RTL)
        load_bodies(s_axis_body, num_bodies, body_ref, body_vel, body_q, err);
        const bool interleaved = (options & kOptInterleaved) != 0;
#if PGS_SOFT_CONTACT
        const SoftKeep soft = {(options & kOptSoftContact) != 0, from_bits(keep_dyn), from_bits(keep_static)};
#else
        const SoftKeep soft = {false, 1.0f, 1.0f};
#endif
    PASSES:
        for (uint32_t p = 0; p < 2 * iterations; p++) {
#pragma HLS LOOP_TRIPCOUNT min=2 max=64 avg=8
            const uint32_t it = pass_iteration(p, iterations, interleaved);
            if (pass_is_friction(p, iterations, interleaved))
                friction_pass(s_axis_cons, trace, num_bodies, num_manifolds, it, body_ref, body_vel, PGS_IMPULSE_CALL,
                              err);
            else
                contact_pass(s_axis_cons, trace, num_bodies, num_manifolds, it, body_ref, body_vel, PGS_IMPULSE_CALL,
                             soft, err);
            count += num_manifolds;
        }
        const Vec3 gravity = vec3(from_bits(gravity_x), from_bits(gravity_y), from_bits(gravity_z));
        const IntegConsts kc = integ_consts(from_bits(dt), gravity, from_bits(damping));
        integrate_out(m_axis_body, num_bodies, kc, body_ref, body_vel, body_q);
    }
    *status = err.status();
    *issued = count;
}
