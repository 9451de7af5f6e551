// pgs_kernel.cpp: the PGS kernel as Vitis HLS C++, with the structure of the 2018 thesis (a single function
// holding the Projected Gauss-Seidel contact and friction solvers and the integration):
//
//   * AXI4-Stream arguments (s_axis_body, s_axis_cons in, m_axis_body out, with TLAST; trace out) in the record
//     layouts of models/kernel/stream_format.py (pgs_stream.h), and an s_axilite bundle `control` with the register
//     map of rtl/README.md;
//   * the body table and the accumulated impulses in on-chip arrays (BRAM): the body-in records are streamed
//     in once, each pass streams one constraint record per manifold, the integration streams the bodies out;
//     built with PGS_IMPULSES_IN_RECORDS = 1 (the RTL's IMPULSES_IN_RECORDS, the design that fits the ZCU102) there
//     is no impulse array: each record carries the impulses its pass starts from and the updated ones leave on
//     m_axis_imp, one record per slot and pass (the DMA writes them to the DDR buffer the next passes read); with
//     PGS_TANGENTS_ON_CHIP = 1 as well (the RTL's TANGENTS_ON_CHIP) the friction records carry no t0, t1 and the
//     friction pass derives them from n (pgs_solver.h plane_space, models/setup/tangent_basis.py);
//   * built with PGS_WINDOW = N > 0 (the RTL's window kernel with the impulses in the records, the fitting window
//     design) each fetch of the records serves several passes of one kind: the fetch's window records (PGS_LANES
//     slots each) go into an on-chip ring of N records, its passes trail each other by `lag` records over it, an
//     impulse ring carries each slot's impulses from pass to pass, and the fetch's last pass writes them to
//     m_axis_imp (window_passes below);
//   * one pipelined loop per pass kind (PIPELINE, the fixed-size inner loops unrolled), ARRAY_PARTITION of the
//     per-body and per-slot words so that a record reads and writes all of them at once, and DEPENDENCE
//     inter false on the body velocities and the impulses (below);
//   * with PGS_SHARED_DATAPATH = 1 (the default, the RTL's SHARED_DATAPATH) both kinds' manifold-passes run on one
//     datapath (lane_pass: generated/pgs_shared_datapath.h, each operator once with its operands chosen by the
//     record's kind; INLINE off and one instance allocated), else each kind on its own (pgs_solver.h).
//
// DEPENDENCE: within a pass every impulse slot is read and written by one record only, so the false
// dependence on imp_n / imp_t is exact. The velocities are not: a manifold reads the velocities of its
// bodies, which a manifold still in the pipeline may be about to write. Like the thesis (and the GPU code) the
// kernel declares that dependence false; the results equal the sequential (golden) order only when no two
// manifolds within the pipeline's depth share a dynamic body, which the host's hazard schedule
// (models/order/manifold_schedule.py, window >= records in flight) guarantees. The RTL kernel's hazard CAM, which makes any
// order exact, has no counterpart here. Passes do not overlap: each pass loop drains before the next starts.
// C simulation is sequential and therefore exact for every order; its testbench counts the records that
// would read a velocity still in flight (hls_export/README.md).
//
// Arithmetic: pgs_fp.h (golden rounding rules); operation order: pgs_solver.h.
#include "pgs_kernel.h"

#include "pgs_solver.h"
#if PGS_SHARED_DATAPATH
#include "generated/pgs_shared_datapath.h"
#endif

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

// A body's constants as a shock pass's row takes them (the header bits; models/golden/contact_solver.py _Gathered.freeze):
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

// --- one manifold-pass (the streaming kernel's passes and the window kernel's) --------------------------------
// One contact manifold-pass of record r in slot `slot`: its bodies gathered, lam[0..3] updated from the impulses
// the pass starts from, the dynamic bodies' velocities written back; returns its trace record.
#if PGS_SHARED_DATAPATH
// --- the shared datapath of a lane (the RTL's SHARED_DATAPATH = 1): one datapath for both kinds ---------------------
// generated/pgs_shared_datapath.h holds the datapath of every option set (rtl/gen/shared_datapath.py binds the friction
// pass onto the contact pass's operators); the kernel's options pick one. Its inputs (rtl/gen/kernel_graphs.py
// shared_in): the record's words after the header (23 slots: a contact record's n, p[4], jac_inv, b; a friction
// record's n, c, t0, t1 (not with the tangents derived on chip), f_jac_inv, the coefficient word), lam[4], lamT[2],
// xA, xB, vA, wA, vB, wB, mInvA, mInvB, IInvA, IInvB, (soft contact) keep_dyn, keep_static.
#if PGS_SOFT_CONTACT && PGS_TANGENTS_ON_CHIP
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_soft_tb
#elif PGS_SOFT_CONTACT && PGS_MU_W
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_mu_soft
#elif PGS_SOFT_CONTACT
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_soft
#elif PGS_TANGENTS_ON_CHIP
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_tb
#elif PGS_IINV_W == 1 && PGS_MU_W
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_scalar_mu
#elif PGS_IINV_W == 1
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_scalar
#elif PGS_IINV_W == 6 && PGS_MU_W
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_full_mu
#elif PGS_IINV_W == 6
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_full
#elif PGS_MU_W
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe_mu
#else
#define PGS_LANE_DATAPATH shared::pgs_shared_pipe
#endif
constexpr int kRecordSlots = 23;  // the shared layout's record words
constexpr int kLaneIn = kRecordSlots + 6 + 20 + 2 * kIInvWords + (kSoftContact ? 2 : 0);

// One manifold-pass of either kind on the lane's datapath: rec the kind's record words, lam / lam_t the impulses the
// pass starts from (a friction pass's lam: its friction limit); on return imp the pass's impulses (contact lam[0..3];
// friction lamT[0..1], 0, 0) and the bodies' velocities in p.
void lane_pass(bool friction, const float rec[kRecordSlots], BodyPair& p, const float lam[4], const float lam_t[2],
               bool spin_damp, const SoftKeep& soft, float imp[4]) {
#pragma HLS INLINE off
    float in[kLaneIn];
#pragma HLS ARRAY_PARTITION variable=in type=complete
    for (int k = 0; k < kRecordSlots; k++) in[k] = rec[k];
    for (int i = 0; i < 4; i++) in[kRecordSlots + i] = lam[i];
    for (int j = 0; j < 2; j++) in[kRecordSlots + 4 + j] = lam_t[j];
    const Vec3 body[6] = {p.A.x, p.B.x, p.va.v, p.va.w, p.vb.v, p.vb.w};
    int at = kRecordSlots + 6;
    for (int b = 0; b < 6; b++) {
        in[at++] = body[b].x;
        in[at++] = body[b].y;
        in[at++] = body[b].z;
    }
    in[at++] = p.A.m_inv;
    in[at++] = p.B.m_inv;
    for (int k = 0; k < kIInvWords; k++) in[at++] = p.A.i_inv.k[k];
    for (int k = 0; k < kIInvWords; k++) in[at++] = p.B.i_inv.k[k];
    if (kSoftContact) {
        in[at++] = soft.dyn;
        in[at++] = soft.stat;
    }
    float out[16];
#if PGS_SOFT_CONTACT
    PGS_LANE_DATAPATH(friction, in, spin_damp, soft.on, out);
#else
    (void)soft;
    PGS_LANE_DATAPATH(friction, in, spin_damp, out);
#endif
    for (int i = 0; i < 4; i++) imp[i] = out[i];
    p.va.v = vec3(out[4], out[5], out[6]);
    p.va.w = vec3(out[7], out[8], out[9]);
    p.vb.v = vec3(out[10], out[11], out[12]);
    p.vb.w = vec3(out[13], out[14], out[15]);
}
#endif

trace_t contact_update(const ContactRec& r, uint32_t slot, uint32_t iteration, uint32_t num_bodies,
                       const float body_ref[kMaxBodies][kRefWords], float body_vel[kMaxBodies][6], float lam[4],
                       const SoftKeep& soft, Errors& err) {
    BodyPair p = gather(r.h, num_bodies, body_ref, body_vel, err);
#if PGS_SHARED_DATAPATH
    float rec[kRecordSlots];
    rec[0] = r.n.x;
    rec[1] = r.n.y;
    rec[2] = r.n.z;
    for (int i = 0; i < 4; i++) {
        rec[3 + 3 * i] = r.p[i].x;
        rec[4 + 3 * i] = r.p[i].y;
        rec[5 + 3 * i] = r.p[i].z;
        rec[15 + i] = r.jac_inv[i];
        rec[19 + i] = r.bias[i];
    }
    const float lam_t[2] = {0.0f, 0.0f};
    float start[4] = {lam[0], lam[1], lam[2], lam[3]};
    lane_pass(false, rec, p, start, lam_t, false, soft, lam);
#else
    solve_contact(r, p.A, p.B, p.va, p.vb, lam, soft);
#endif
    retire(body_vel, p);
    return encode_trace(lam, p.va.v, p.va.w, p.vb.v, p.vb.w, slot, iteration, false);
}

// One friction manifold-pass of record r: lam_n the manifold's normal impulses (its friction limit); impulses[0..1]
// the lamT the pass starts from, on return {lamT[0], lamT[1], 0, 0} (the trace's and the impulse-out record's words).
trace_t friction_update(FrictionRec r, uint32_t slot, uint32_t iteration, uint32_t num_bodies,
                        const float body_ref[kMaxBodies][kRefWords], float body_vel[kMaxBodies][6],
                        const float lam_n[4], float impulses[4], Errors& err) {
    BodyPair p = gather(r.h, num_bodies, body_ref, body_vel, err);
    float lam_t[2] = {impulses[0], impulses[1]};
#if PGS_SHARED_DATAPATH
    // the record's words: n, c, t0, t1 (the datapath derives them with the tangents on chip), f_jac_inv, the coefficient
    float rec[kRecordSlots] = {};
    int at = 0;
    const Vec3 vecs[4] = {r.n, r.c, r.t[0], r.t[1]};
    for (int v = 0; v < (kTangentsOnChip ? 2 : 4); v++) {
        rec[at++] = vecs[v].x;
        rec[at++] = vecs[v].y;
        rec[at++] = vecs[v].z;
    }
    rec[at++] = r.f_jac_inv[0];
    rec[at++] = r.f_jac_inv[1];
    if (kMuWords) rec[at] = r.mu;
    const SoftKeep rigid = {false, 0.0f, 0.0f};
    lane_pass(true, rec, p, lam_n, lam_t, r.h.spin_damp && !r.h.shock_linear, rigid, impulses);
#else
    if (kTangentsOnChip) plane_space(r.n, r.t);  // the record carries no t0, t1: derived from n
    solve_friction(r, p.A, p.B, p.va, p.vb, lam_n, lam_t);
    impulses[0] = lam_t[0];
    impulses[1] = lam_t[1];
    impulses[2] = 0.0f;
    impulses[3] = 0.0f;
#endif
    retire(body_vel, p);
    return encode_trace(impulses, p.va.v, p.va.w, p.vb.v, p.vb.w, slot, iteration, true);
}

#if !PGS_WINDOW
// --- the streaming kernel: every pass streams its records ----------------------------------------------------
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
        float lam[4];
#if PGS_IMPULSES_IN_RECORDS
        for (int i = 0; i < 4; i++) lam[i] = r.lam[i];
#else
        for (int i = 0; i < 4; i++) lam[i] = zero_lam ? 0.0f : imp_n[k][i];
#endif
        trace.write(contact_update(r, k, iteration, num_bodies, body_ref, body_vel, lam, soft, err));
#if PGS_IMPULSES_IN_RECORDS
        write_impulses(m_axis_imp, lam, k == num_manifolds - 1);
#else
        for (int i = 0; i < 4; i++) imp_n[k][i] = lam[i];
#endif
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
        const FrictionRec r = decode_friction(read_cons<kFrictionBeats>(s_axis_cons, k == num_manifolds - 1, err));
        float lam_n[4], impulses[4] = {0.0f, 0.0f, 0.0f, 0.0f};
#if PGS_IMPULSES_IN_RECORDS
        for (int i = 0; i < 4; i++) lam_n[i] = r.lam[i];
        for (int j = 0; j < 2; j++) impulses[j] = r.lam_t[j];
#else
        for (int i = 0; i < 4; i++) lam_n[i] = imp_n[k][i];
        for (int j = 0; j < 2; j++) impulses[j] = zero_lam ? 0.0f : imp_t[k][j];
#endif
        trace.write(friction_update(r, k, iteration, num_bodies, body_ref, body_vel, lam_n, impulses, err));
#if PGS_IMPULSES_IN_RECORDS
        write_impulses(m_axis_imp, impulses, k == num_manifolds - 1);
#else
        for (int j = 0; j < 2; j++) imp_t[k][j] = impulses[j];
#endif
    }
}

#else
// --- the window kernel (PGS_WINDOW > 0): one fetch of the records serves several passes -------------------------
// The window arguments refused (error 3, the RTL's argument check): fetch_passes outside 1..kWindowCtx, lag 0, a
// ring too small for the fetch's passes trailing each other ((fetch_passes - 1) lag + 2 > kWindow), num_manifolds
// not a multiple of the lanes, or a fetch that would serve contact and friction passes together (fetch_passes must
// divide the iterations, or be 1 with the kinds interleaved: models.kernel.stream_format.window_fetch_kinds).
bool window_args_ok(uint32_t num_manifolds, uint32_t iterations, bool interleaved, uint32_t lag,
                    uint32_t fetch_passes) {
    if (fetch_passes < 1 || fetch_passes > uint32_t(kWindowCtx) || lag < 1) return false;
    if (uint64_t(fetch_passes - 1) * lag + 2 > uint64_t(kWindow) || num_manifolds % kLanes != 0) return false;
    return interleaved ? fetch_passes == 1 : iterations % fetch_passes == 0;
}

// BEATS beats of a wide record, from beat `at` (a window record's lane, a lane's record of the fetch's kind).
template <int BEATS, int N>
ap_uint<BEATS * kConsW> beats_at(const ap_uint<N>& rec, int at) {
    return rec.range((at + BEATS) * kConsW - 1, at * kConsW);
}

// The window kernel reads a record once for several passes: a shock pass's header bits are ignored (as the RTL's).
Header without_shock(Header h) {
    h.frozen_a = false;
    h.frozen_b = false;
    h.shock_linear = false;
    return h;
}

// The impulse a pass of the fetch starts from: the record's (the fetch's first pass) or the one the pass before it
// left in the impulse ring.
float start_impulse(bool first, float from_record, float from_ring) { return first ? from_record : from_ring; }

// One pass of the fetch over a window record, and where it stands in the step.
struct WindowPass {
    uint32_t pass, iteration;
    bool friction;  // the fetch's kind
    bool first;     // the fetch's first pass: the impulses are the record's
    bool last;      // the fetch's last pass: it writes the impulse-out record
};

// Pass wp of window record r (ring address `at`): every lane that issues is solved, one after the other (the lanes
// share no dynamic body: the same as together), and leaves its impulses in the impulse ring for the fetch's next
// pass; the fetch's last pass writes the record's impulse-out record (lane l's 4 words at 4 l; zeros for a lane that
// does not issue), TLAST on the fetch's last record. An empty lane (header all ones) never issues. A lane that shares
// a dynamic body with an earlier issuing lane of its record is rejected (error 4), and a slot rejected in an earlier
// pass of the step stays rejected (`rejected`, written for every slot in pass 0): no trace, no velocity write.
void window_record_pass(const window_bits_t& rec, uint32_t at, uint32_t r, uint32_t nrec, const WindowPass& wp,
                        uint32_t num_bodies, const float body_ref[kMaxBodies][kRefWords], float body_vel[kMaxBodies][6],
                        float imp_ring[kWindow][kLanes][4], bool rejected[kMaxManifolds],
                        hls::stream<trace_t>& trace, hls::stream<imp_beat_t>& m_axis_imp, const SoftKeep& soft,
                        Errors& err, uint32_t& issued) {
    float out[kLanes * kImpulseOutWords];
    bool go[kLanes];
    uint32_t go_a[kLanes], go_b[kLanes];  // the issuing lanes' bodies
LANES:
    for (int l = 0; l < kLanes; l++) {
#pragma HLS UNROLL
        go[l] = false;
        go_a[l] = go_b[l] = 0;
        for (int i = 0; i < 4; i++) out[4 * l + i] = 0.0f;
        const ap_uint<kWindowBeats * kConsW> lane = beats_at<kWindowBeats>(rec, l * kWindowBeats);
        if (lane.range(kHeaderBits - 1, 0).to_uint64() == ~0ull) continue;  // an empty lane
        const Header h = header_at(lane);
        const uint32_t a = h.body_a & (kMaxBodies - 1), b = h.body_b & (kMaxBodies - 1);
        const bool dyn_a = body_ref[a][3] != 0.0f, dyn_b = body_ref[b][3] != 0.0f;
        bool collide = false;
        for (int k = 0; k < l; k++) {
#pragma HLS UNROLL
            if (go[k] && ((dyn_a && (a == go_a[k] || a == go_b[k])) || (dyn_b && (b == go_a[k] || b == go_b[k]))))
                collide = true;
        }
        const uint32_t slot = r * kLanes + l;
        const bool rej = (wp.pass != 0 && rejected[slot]) || collide;
        rejected[slot] = rej;
        if (collide) err.raise(kErrBodyIndex);
        if (rej) continue;
        go[l] = true;
        go_a[l] = a;
        go_b[l] = b;
        float imp[4];
        trace_t t;
        if (wp.friction) {
            FrictionRec f = decode_friction(beats_at<kFrictionBeats>(lane, 0));
            f.h = without_shock(f.h);
            for (int j = 0; j < 2; j++) imp[j] = start_impulse(wp.first, f.lam_t[j], imp_ring[at][l][j]);
            t = friction_update(f, slot, wp.iteration, num_bodies, body_ref, body_vel, f.lam, imp, err);
        } else {
            ContactRec c = decode_contact(beats_at<kContactBeats>(lane, 0));
            c.h = without_shock(c.h);
            for (int i = 0; i < 4; i++) imp[i] = start_impulse(wp.first, c.lam[i], imp_ring[at][l][i]);
            t = contact_update(c, slot, wp.iteration, num_bodies, body_ref, body_vel, imp, soft, err);
        }
        for (int i = 0; i < 4; i++) {
            imp_ring[at][l][i] = imp[i];
            out[4 * l + i] = imp[i];
        }
        trace.write(t);
        issued++;
    }
    if (wp.last) write_record<1, kImpOutW>(m_axis_imp, encode_impulse_out(out), r == nrec - 1);
}

// The window kernel's passes (models/kernel/record_window.py): ceil(passes / fetch_passes) fetches, each of one kind, each
// reading num_manifolds / kLanes window records into the ring and running its np passes over them, pass k trailing
// pass k - 1 by `lag` records: at time t the fetch reads record t (t < nrec) and pass k processes record t - k lag,
// the passes in ascending order. With lag >= D (the band width of the slot order) every body sees its updates in the
// sequential solve's order, and every pass reads the slot's impulses after the pass before it wrote them. A fetch's
// passes end before the next fetch starts, so the DMA reads the next fetch's records with every impulse it wrote.
// DEPENDENCE false on the velocities and the impulse ring (as the streaming passes'): the records of the pass
// schedule follow each other in the pipelined PASSES loop, exact only while no two of them within the pipeline's
// depth share a dynamic body (the testbench's window_hazards counts the others). Returns the manifold-passes issued.
uint32_t window_passes(hls::stream<cons_beat_t>& s_axis_cons, hls::stream<trace_t>& trace,
                       hls::stream<imp_beat_t>& m_axis_imp, uint32_t num_bodies, uint32_t num_manifolds,
                       uint32_t iterations, bool interleaved, uint32_t lag, uint32_t fetch_passes,
                       const float body_ref[kMaxBodies][kRefWords], float body_vel[kMaxBodies][6],
                       const SoftKeep& soft, Errors& err) {
    // the ring of window records (block RAM), the impulse ring (4 words per lane at the record's ring address), and
    // one bit per slot: rejected earlier in the step
    static window_bits_t ring[kWindow];
    static float imp_ring[kWindow][kLanes][4];
    static bool rejected[kMaxManifolds];
#pragma HLS BIND_STORAGE variable=ring type=ram_t2p impl=bram
#pragma HLS ARRAY_PARTITION variable=imp_ring type=complete dim=2
#pragma HLS ARRAY_PARTITION variable=imp_ring type=complete dim=3
#pragma HLS BIND_STORAGE variable=imp_ring type=ram_t2p impl=bram
#pragma HLS BIND_STORAGE variable=rejected type=ram_t2p impl=bram
    const uint32_t nrec = num_manifolds / kLanes, passes = 2 * iterations;
    uint32_t issued = 0;
FETCHES:
    for (uint32_t p0 = 0; p0 < passes; p0 += fetch_passes) {
#pragma HLS LOOP_TRIPCOUNT min=1 max=64 avg=2
        const uint32_t np = passes - p0 < fetch_passes ? passes - p0 : fetch_passes;
        const bool friction = pass_is_friction(p0, iterations, interleaved);  // every pass of the fetch's
        const uint32_t span = nrec == 0 ? 0 : nrec + (np - 1) * lag;
    TIME:
        for (uint32_t t = 0; t < span; t++) {
#pragma HLS LOOP_TRIPCOUNT min=1 max=131072 avg=64000
            if (t < nrec) ring[t & (kWindow - 1)] = read_cons<kWindowRecBeats>(s_axis_cons, t == nrec - 1, err);
        PASSES:
            for (uint32_t k = 0; k < np; k++) {
#pragma HLS PIPELINE II=1
#pragma HLS LOOP_TRIPCOUNT min=1 max=8 avg=4
#pragma HLS DEPENDENCE variable=body_vel type=inter dependent=false
#pragma HLS DEPENDENCE variable=imp_ring type=inter dependent=false
                if (t < k * lag || t - k * lag >= nrec) continue;  // pass k has not started, or is done
                const uint32_t r = t - k * lag, p = p0 + k;
                const WindowPass wp = {p, pass_iteration(p, iterations, interleaved), friction, k == 0, k == np - 1};
                window_record_pass(ring[r & (kWindow - 1)], r & (kWindow - 1), r, nrec, wp, num_bodies, body_ref,
                                   body_vel, imp_ring, rejected, trace, m_axis_imp, soft, err, issued);
            }
        }
    }
    return issued;
}
#endif

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
                PGS_WINDOW_PORTS uint32_t* status, uint32_t* issued) {
#pragma HLS INTERFACE mode=axis port=s_axis_body
#pragma HLS INTERFACE mode=axis port=s_axis_cons
#pragma HLS INTERFACE mode=axis port=m_axis_body
#pragma HLS INTERFACE mode=axis port=trace
#if PGS_IMPULSES_IN_RECORDS
#pragma HLS INTERFACE mode=axis port=m_axis_imp
#endif
    // the argument offsets of models/kernel/register_map.py (generated/pgs_regs.h: PGS_PRAGMA expands PGS_REG_*)
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
#if PGS_WINDOW
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=lag bundle=control offset=PGS_REG_LAG)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=fetch_passes bundle=control offset=PGS_REG_FETCH_PASSES)
#endif
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=status bundle=control offset=PGS_REG_STATUS)
    PGS_PRAGMA(HLS INTERFACE mode=s_axilite port=issued bundle=control offset=PGS_REG_ISSUED)
#pragma HLS INTERFACE mode=s_axilite port=return bundle=control
#if PGS_SHARED_DATAPATH
    // one datapath for the contact and the friction manifold-passes (they never run in the same cycle: the passes are
    // loops one after the other, the window design's records of one kind per fetch)
#pragma HLS ALLOCATION function instances=lane_pass limit=1
#endif

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
    const bool interleaved = (options & kOptInterleaved) != 0;
#if PGS_WINDOW
    const bool window_ok = window_args_ok(num_manifolds, iterations, interleaved, lag, fetch_passes);
#else
    const bool window_ok = true;
#endif
    if (num_bodies > kMaxBodies || num_manifolds > kMaxManifolds || iterations > kMaxIterations || !window_ok) {
        err.raise(kErrBadArgs);  // the step ends at once, streams untouched
    } else if (num_bodies != 0) {  // no bodies: nothing to load, solve or integrate (as the RTL)
        load_bodies(s_axis_body, num_bodies, body_ref, body_vel, body_q, err);
#if PGS_SOFT_CONTACT
        const SoftKeep soft = {(options & kOptSoftContact) != 0, from_bits(keep_dyn), from_bits(keep_static)};
#else
        const SoftKeep soft = {false, 1.0f, 1.0f};
#endif
#if PGS_WINDOW
        count = window_passes(s_axis_cons, trace, m_axis_imp, num_bodies, num_manifolds, iterations, interleaved, lag,
                              fetch_passes, body_ref, body_vel, soft, err);
#else
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
#endif
        const Vec3 gravity = vec3(from_bits(gravity_x), from_bits(gravity_y), from_bits(gravity_z));
        const IntegConsts kc = integ_consts(from_bits(dt), gravity, from_bits(damping));
        integrate_out(m_axis_body, num_bodies, kc, body_ref, body_vel, body_q);
    }
    *status = err.status();
    *issued = count;
}
