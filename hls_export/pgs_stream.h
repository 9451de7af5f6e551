// pgs_stream.h: the kernel's AXI4-Stream records, bit for bit as models/kernel/stream_format.py packs them, and the
// trace record of rtl/README.md.
//
// Every record is little-endian from bit 0 and padded to whole beats (beat j holds record bits
// [j*B, (j+1)*B)). Words are W = 1 + PGS_EXP_BITS + PGS_MAN_BITS bits (pgs_fp.h; binary32 by default); word k of
// a record with a header sits at bits [64 + W k, 64 + W k + W).
//   contact   header, n(3), p[0..3] xyz (12), jac_inv(4), b(4)         64 + 23 W bits
//             PGS_IMPULSES_IN_RECORDS = 1: then lam[0..3]               64 + 27 W bits
//   friction  header, n(3), c(3), t0(3), t1(3), f_jac_inv(2), mu (PGS_MU_W = 1)   64 + (14 + PGS_MU_W) W bits
//             PGS_IMPULSES_IN_RECORDS = 1: then lam[0..3], lamT[0..1]  64 + (20 + PGS_MU_W) W bits
//             PGS_TANGENTS_ON_CHIP = 1 (with PGS_IMPULSES_IN_RECORDS = 1, PGS_MU_W = 0, PGS_IINV_W = 3): without t0,
//             t1 (the kernel derives them from n, pgs_solver.h plane_space): n, c, f_jac_inv, lam, lamT  64 + 14 W bits
//   impulse-out (m_axis_imp, PGS_IMPULSES_IN_RECORDS = 1)  contact lam[0..3]; friction lamT[0..1], 0, 0
//             4 W bits rounded up to whole bytes, one per slot of every pass, TLAST on a pass's last
//   window    (PGS_WINDOW > 0, with PGS_IMPULSES_IN_RECORDS = 1) PGS_LANES lane records one after the other, each
//             its fetch's kind's record above (with its impulses) padded to kWindowBeats beats (the longer kind's);
//             an empty lane: header all ones, zero words. Impulse-out: one per window record of a fetch's last
//             pass, its lanes' 4 words one after the other, 4 L W bits rounded up to whole bytes
//   header    bits 31:0 body_a, 59:32 body_b, 60 frozen A, 61 frozen B, 62 linear shock, 63 spin_damp (the three
//             shock bits only in a shock pass's records, models/golden/shock_propagation.py; positions kHeader*Bit)
//   body-in   pos(3), q(4) (x, y, z, w), v(3), w(3), inv_mass, inv_inertia(PGS_IINV_W)   (14 + PGS_IINV_W) W bits
//   body-out  pos(3), q(4), v(3), w(3)                                           13 W bits
//   trace     impulses[0..3] (friction: lamT[0..1], 0, 0), vA, wA, vB, wB (16 W bits), then slot (32 bits),
//             iteration (16 bits), kind (1 bit: 0 contact, 1 friction), 15 zero bits    16 W + 64 bits
// Beat widths (build-time, as the RTL's parameters): PGS_CONS_W (512), PGS_BODY_IN_W (128), PGS_BODY_OUT_W
// (128).
#ifndef PGS_STREAM_H
#define PGS_STREAM_H

#include <cstdint>

#include "generated/pgs_stream_layout.h"
#include "pgs_fp.h"
#include "pgs_hls.h"

#ifndef PGS_CONS_W
#define PGS_CONS_W 512
#endif
#ifndef PGS_IINV_W
#define PGS_IINV_W 3  // inverse-inertia words per body (the RTL's IINV_W): 1 scalar, 3 diagonal, 6 xx yy zz xy xz yz
#endif
#ifndef PGS_MU_W
#define PGS_MU_W 0  // friction-coefficient words per friction record (the RTL's MU_W): 0 the constant, 1 a word
#endif
#ifndef PGS_IMPULSES_IN_RECORDS
#define PGS_IMPULSES_IN_RECORDS 0  // 1: the impulses travel with the records and leave on m_axis_imp (no impulse RAM)
#endif
#ifndef PGS_TANGENTS_ON_CHIP
#define PGS_TANGENTS_ON_CHIP 0  // 1: friction records without t0, t1, derived from n (the RTL's TANGENTS_ON_CHIP)
#endif
#ifndef PGS_WINDOW
#define PGS_WINDOW 0  // > 0: the window kernel with a ring of that many records (the RTL's WINDOW; a power of two)
#endif
#ifndef PGS_WINDOW_CTX
#define PGS_WINDOW_CTX 8  // the window kernel's most passes per fetch (the RTL's WINDOW_CTX)
#endif
#ifndef PGS_LANES
#define PGS_LANES 1  // slots per window record, solved together (the RTL's LANES; > 1 with PGS_WINDOW > 0 only)
#endif
#ifndef PGS_BODY_IN_W
#define PGS_BODY_IN_W 128
#endif
#ifndef PGS_BODY_OUT_W
#define PGS_BODY_OUT_W 128
#endif

namespace pgs {

// the record sizes and the impulse words' offsets (kHeaderBits, k*Words, k*LamWord, kTraceTailBits) are
// generated/pgs_stream_layout.h, from models/kernel/stream_format.py; the words are those of the format (pgs_fp.h)
constexpr int kWordBits = kFormatBits;
constexpr int kTraceBits = kTraceWords * kWordBits + kTraceTailBits;

constexpr int beats_for(int record_bits, int beat_bits) { return (record_bits + beat_bits - 1) / beat_bits; }

constexpr int kConsW = PGS_CONS_W;
constexpr int kBodyInW = PGS_BODY_IN_W;
constexpr int kBodyOutW = PGS_BODY_OUT_W;
constexpr bool kImpulsesInRecords = PGS_IMPULSES_IN_RECORDS != 0;
static_assert(PGS_IMPULSES_IN_RECORDS == 0 || PGS_IMPULSES_IN_RECORDS == 1, "PGS_IMPULSES_IN_RECORDS must be 0 or 1");
constexpr int kMuWords = PGS_MU_W;
static_assert(kMuWords == 0 || kMuWords == 1, "PGS_MU_W must be 0 or 1");
constexpr bool kTangentsOnChip = PGS_TANGENTS_ON_CHIP != 0;
static_assert(PGS_TANGENTS_ON_CHIP == 0 || PGS_TANGENTS_ON_CHIP == 1, "PGS_TANGENTS_ON_CHIP must be 0 or 1");
static_assert(!kTangentsOnChip || kImpulsesInRecords,
              "PGS_TANGENTS_ON_CHIP = 1 is a configuration of the records design: build it with "
              "PGS_IMPULSES_IN_RECORDS = 1");
static_assert(!kTangentsOnChip || (kMuWords == 0 && PGS_IINV_W == 3),
              "PGS_TANGENTS_ON_CHIP = 1 is built for the diagonal inverse inertia (PGS_IINV_W = 3) and the constant "
              "friction coefficient (PGS_MU_W = 0)");
// the friction record's t0, t1 words (0: derived on chip) and its words before the coefficient: n, c, [t0, t1],
// f_jac_inv (StreamLayout._tangent_words; the generated counts include the tangents)
constexpr int kFrictionTangentWords = kTangentsOnChip ? 0 : kTangentWords;
constexpr int kFrictionStaticWords = kFrictionWords - kTangentWords + kFrictionTangentWords;
constexpr int kFrictionJacInvAt = kFrictionStaticWords - 2;  // f_jac_inv[0..1], the last two of them
// words after the header (models.kernel.stream_format.StreamLayout.contact_record_words / friction_record_words)
constexpr int kContactRecordWords = kContactWords + (kImpulsesInRecords ? kContactImpulseWords : 0);
constexpr int kFrictionRecordWords = kFrictionStaticWords + kMuWords + (kImpulsesInRecords ? kFrictionImpulseWords : 0);
// StreamLayout.friction_lam_word, friction_lamt_word
constexpr int kFrictionLamAt = kFrictionLamWord - kTangentWords + kFrictionTangentWords + kMuWords;
constexpr int kFrictionLamtAt = kFrictionLamtWord - kTangentWords + kFrictionTangentWords + kMuWords;
constexpr int kContactBeats = beats_for(kHeaderBits + kContactRecordWords * kWordBits, kConsW);
constexpr int kFrictionBeats = beats_for(kHeaderBits + kFrictionRecordWords * kWordBits, kConsW);
// the window kernel (models/kernel/record_window.py): ring depth, passes per fetch at most, lanes per record
constexpr int kWindow = PGS_WINDOW;
constexpr int kWindowCtx = PGS_WINDOW_CTX;
constexpr int kLanes = PGS_LANES;
static_assert(kWindow == 0 || (kWindow >= 2 && (kWindow & (kWindow - 1)) == 0),
              "PGS_WINDOW must be 0 (the streaming kernel) or a power of two >= 2 (the ring's records)");
static_assert(kWindowCtx >= 2 && (kWindowCtx & (kWindowCtx - 1)) == 0, "PGS_WINDOW_CTX must be a power of two >= 2");
static_assert(kLanes == 1 || kLanes == 2 || kLanes == 4, "PGS_LANES must be 1, 2 or 4");
static_assert(kLanes == 1 || kWindow > 0, "PGS_LANES > 1 is a configuration of the window kernel (PGS_WINDOW > 0)");
static_assert(kWindow == 0 || kImpulsesInRecords,
              "the window kernel is written with the impulses in the records only (PGS_IMPULSES_IN_RECORDS = 1): "
              "no on-chip impulse RAM");
static_assert(kWindow == 0 || !kTangentsOnChip,
              "the window kernel streams the friction tangents (PGS_TANGENTS_ON_CHIP = 0)");
constexpr int kImpOutW = (kLanes * kImpulseOutWords * kWordBits + 7) / 8 * 8;  // m_axis_imp TDATA: whole bytes
constexpr int kIInvWords = PGS_IINV_W;
static_assert(kIInvWords == 1 || kIInvWords == 3 || kIInvWords == 6, "PGS_IINV_W must be 1, 3 or 6");
static_assert(kBodyInInvInertia + 3 == kBodyInWords, "the default body-in record carries 3 inverse-inertia words");
constexpr int kBodyInRecordWords = kBodyInInvInertia + kIInvWords;
// a lane record of the window kernel: the longer kind's beats (StreamLayout.window_beats); a window record: L of them
constexpr int kWindowBeats = kContactBeats > kFrictionBeats ? kContactBeats : kFrictionBeats;
constexpr int kWindowRecBeats = kLanes * kWindowBeats;
constexpr int kBodyInBeats = beats_for(kBodyInRecordWords * kWordBits, kBodyInW);
constexpr int kBodyOutBeats = beats_for(kBodyOutWords * kWordBits, kBodyOutW);

static_assert(kHeaderBodyBLsb == 32 && kHeaderBodyBLsb + kHeaderBodyBBits <= kHeaderFrozenABit &&
                  kHeaderSpinDampBit < kHeaderBits,
              "the header's fields: body_a in bits 31:0, body_b below the shock bits, all within the header");

typedef ap_axiu<kConsW, 0, 0, 0> cons_beat_t;
typedef ap_axiu<kBodyInW, 0, 0, 0> body_in_beat_t;
typedef ap_axiu<kBodyOutW, 0, 0, 0> body_out_beat_t;
typedef ap_axiu<kImpOutW, 0, 0, 0> imp_beat_t;
typedef ap_uint<kTraceBits> trace_t;

typedef ap_uint<kContactBeats * kConsW> contact_bits_t;
typedef ap_uint<kFrictionBeats * kConsW> friction_bits_t;
typedef ap_uint<kWindowRecBeats * kConsW> window_bits_t;
typedef ap_uint<kBodyInBeats * kBodyInW> body_in_bits_t;
typedef ap_uint<kBodyOutBeats * kBodyOutW> body_out_bits_t;

struct Vec3 {
    float x, y, z;
};

// A constraint record's header. A shock pass's row (models/golden/shock_propagation.py) may have one body frozen: the
// contact and friction update take it as a static body (inverse mass and inertia +0, velocities not written back);
// a linear shock row takes both bodies' inverse inertia as +0 and is not spin-damped (pgs_kernel.cpp shock_row).
struct Header {
    uint32_t body_a, body_b;
    bool frozen_a, frozen_b;  // a shock pass's row: body A / body B frozen
    bool shock_linear;        // a linear shock row: no inverse inertia, no spin damping
    bool spin_damp;
};

struct ContactRec {
    Header h;
    Vec3 n;
    Vec3 p[4];
    float jac_inv[4];
    float bias[4];
    float lam[4];  // the impulses the pass starts from (PGS_IMPULSES_IN_RECORDS = 1; else unused)
};

struct FrictionRec {
    Header h;
    Vec3 n, c;
    Vec3 t[2];  // PGS_TANGENTS_ON_CHIP = 1: not in the record, zeros until the kernel derives them (plane_space)
    float f_jac_inv[2];
    float mu;  // the manifold's friction coefficient (PGS_MU_W = 1; else the constant kFrictionCoeff)
    float lam[4], lam_t[2];  // the manifold's normal impulses and the pass's start (PGS_IMPULSES_IN_RECORDS = 1)
};

// A body's world inverse inertia: the scalar, the diagonal (xx, yy, zz) or the symmetric 3x3 (xx, yy, zz, xy, xz, yz).
struct InvInertia {
    float k[kIInvWords];
};

struct BodyState {
    Vec3 pos;
    float q[4];  // x, y, z, w
    Vec3 v, w;
    float inv_mass;
    InvInertia inv_inertia;
};

// --- beats <-> records --------------------------------------------------------------------------------
// One record of BEATS beats from an AXI4-Stream; `tlast_error` is set when a beat's TLAST differs from
// "last beat of the record that ends the transfer" (`last_record`).
template <int BEATS, int D>
ap_uint<BEATS * D> read_record(hls::stream<ap_axiu<D, 0, 0, 0> >& s, bool last_record, bool& tlast_error) {
    ap_uint<BEATS * D> rec;
    for (int j = 0; j < BEATS; j++) {
#pragma HLS UNROLL
        const ap_axiu<D, 0, 0, 0> beat = s.read();
        rec.range((j + 1) * D - 1, j * D) = beat.data;
        const bool want_last = last_record && j == BEATS - 1;
        if ((beat.last.to_uint() != 0) != want_last) tlast_error = true;
    }
    return rec;
}

// All N bits set (TKEEP / TSTRB of a full beat).
template <int N>
ap_uint<N> all_ones() {
    ap_uint<N> v;
    for (int lo = 0; lo < N; lo += 32) {
#pragma HLS UNROLL
        const int hi = lo + 31 < N ? lo + 31 : N - 1;
        v.range(hi, lo) = 0xFFFFFFFFull;
    }
    return v;
}

template <int BEATS, int D>
void write_record(hls::stream<ap_axiu<D, 0, 0, 0> >& s, const ap_uint<BEATS * D>& rec, bool last_record) {
    for (int j = 0; j < BEATS; j++) {
#pragma HLS UNROLL
        ap_axiu<D, 0, 0, 0> beat;
        beat.data = rec.range((j + 1) * D - 1, j * D);
        beat.keep = all_ones<(D + 7) / 8>();
        beat.strb = all_ones<(D + 7) / 8>();
        beat.user = 0;
        beat.id = 0;
        beat.dest = 0;
        beat.last = (last_record && j == BEATS - 1) ? 1 : 0;
        s.write(beat);
    }
}

// --- words ----------------------------------------------------------------------------------------------
template <int N>
uint32_t word_at(const ap_uint<N>& rec, int base, int k) {
    const int lo = base + k * kWordBits;
    return rec.range(lo + kWordBits - 1, lo).to_uint();
}

template <int N>
float value_at(const ap_uint<N>& rec, int base, int k) {
    return from_bits(word_at(rec, base, k));
}

template <int N>
Vec3 vec_at(const ap_uint<N>& rec, int base, int k) {
    Vec3 v = {value_at(rec, base, k), value_at(rec, base, k + 1), value_at(rec, base, k + 2)};
    return v;
}

template <int N>
void put_word(ap_uint<N>& rec, int base, int k, float x) {
    const int lo = base + k * kWordBits;
    rec.range(lo + kWordBits - 1, lo) = to_bits(x);
}

template <int N>
void put_vec(ap_uint<N>& rec, int base, int k, const Vec3& v) {
    put_word(rec, base, k, v.x);
    put_word(rec, base, k + 1, v.y);
    put_word(rec, base, k + 2, v.z);
}

template <int N>
Header header_at(const ap_uint<N>& rec) {
    Header h;
    h.body_a = rec.range(kHeaderBodyBLsb - 1, 0).to_uint();
    h.body_b = rec.range(kHeaderBodyBLsb + kHeaderBodyBBits - 1, kHeaderBodyBLsb).to_uint();
    h.frozen_a = rec.range(kHeaderFrozenABit, kHeaderFrozenABit).to_uint() != 0;
    h.frozen_b = rec.range(kHeaderFrozenBBit, kHeaderFrozenBBit).to_uint() != 0;
    h.shock_linear = rec.range(kHeaderShockLinearBit, kHeaderShockLinearBit).to_uint() != 0;
    h.spin_damp = rec.range(kHeaderSpinDampBit, kHeaderSpinDampBit).to_uint() != 0;
    return h;
}

// --- records --------------------------------------------------------------------------------------------
inline ContactRec decode_contact(const contact_bits_t& r) {
    ContactRec c;
    c.h = header_at(r);
    c.n = vec_at(r, kHeaderBits, 0);
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        c.p[i] = vec_at(r, kHeaderBits, 3 + 3 * i);
        c.jac_inv[i] = value_at(r, kHeaderBits, 15 + i);
        c.bias[i] = value_at(r, kHeaderBits, 19 + i);
        c.lam[i] = kImpulsesInRecords ? value_at(r, kHeaderBits, kContactLamWord + i) : 0.0f;
    }
    return c;
}

inline FrictionRec decode_friction(const friction_bits_t& r) {
    FrictionRec f;
    f.h = header_at(r);
    f.n = vec_at(r, kHeaderBits, 0);
    f.c = vec_at(r, kHeaderBits, 3);
    const Vec3 zero = {0.0f, 0.0f, 0.0f};
    f.t[0] = kTangentsOnChip ? zero : vec_at(r, kHeaderBits, 6);
    f.t[1] = kTangentsOnChip ? zero : vec_at(r, kHeaderBits, 9);
    f.f_jac_inv[0] = value_at(r, kHeaderBits, kFrictionJacInvAt);
    f.f_jac_inv[1] = value_at(r, kHeaderBits, kFrictionJacInvAt + 1);
    f.mu = kMuWords ? value_at(r, kHeaderBits, kFrictionStaticWords) : 0.0f;
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        f.lam[i] = kImpulsesInRecords ? value_at(r, kHeaderBits, kFrictionLamAt + i) : 0.0f;
    }
    for (int j = 0; j < 2; j++) {
#pragma HLS UNROLL
        f.lam_t[j] = kImpulsesInRecords ? value_at(r, kHeaderBits, kFrictionLamtAt + j) : 0.0f;
    }
    return f;
}

inline BodyState decode_body_in(const body_in_bits_t& r) {
    BodyState b;
    b.pos = vec_at(r, 0, 0);
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        b.q[i] = value_at(r, 0, 3 + i);
    }
    b.v = vec_at(r, 0, 7);
    b.w = vec_at(r, 0, 10);
    b.inv_mass = value_at(r, 0, 13);
    for (int i = 0; i < kIInvWords; i++) {
#pragma HLS UNROLL
        b.inv_inertia.k[i] = value_at(r, 0, kBodyInInvInertia + i);
    }
    return b;
}

inline body_out_bits_t encode_body_out(const BodyState& b) {
    body_out_bits_t r = 0;  // padding bits are zero
    put_vec(r, 0, 0, b.pos);
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        put_word(r, 0, 3 + i, b.q[i]);
    }
    put_vec(r, 0, 7, b.v);
    put_vec(r, 0, 10, b.w);
    return r;
}

// The impulse-out record (m_axis_imp TDATA) of one manifold-pass, or of a window record's lanes: impulses[0..4 L - 1]
// (lane l's 4 words at 4 l), padding bits zero.
inline ap_uint<kImpOutW> encode_impulse_out(const float impulses[kLanes * kImpulseOutWords]) {
    ap_uint<kImpOutW> r = 0;
    for (int i = 0; i < kLanes * kImpulseOutWords; i++) {
#pragma HLS UNROLL
        put_word(r, 0, i, impulses[i]);
    }
    return r;
}

// The trace record of one retired manifold-pass (rtl/README.md "Trace").
inline trace_t encode_trace(const float impulses[4], const Vec3& va, const Vec3& wa, const Vec3& vb, const Vec3& wb,
                            uint32_t slot, uint32_t iteration, bool friction) {
    trace_t t = 0;  // the 15 bits above the kind are zero
    for (int i = 0; i < 4; i++) {
#pragma HLS UNROLL
        put_word(t, 0, i, impulses[i]);
    }
    put_vec(t, 0, 4, va);
    put_vec(t, 0, 7, wa);
    put_vec(t, 0, 10, vb);
    put_vec(t, 0, 13, wb);
    const int tail = kTraceWords * kWordBits;
    t.range(tail + 31, tail) = slot;
    t.range(tail + 47, tail + 32) = iteration & 0xFFFFu;
    t.range(tail + 48, tail + 48) = friction ? 1 : 0;
    return t;
}

}  // namespace pgs

#endif  // PGS_STREAM_H
