// pgs_fp.h: binary32 arithmetic of the kernel, with the rules of the golden model
// (models/number_format.py, whose module docstring is the contract; rtl/fp implements the same):
//
//  * inputs: a subnormal bit pattern reads as a zero of its sign (from_bits);
//  * every +, -, *, /, sqrt is rounded once, to nearest even, with an unbounded exponent; a rounded
//    magnitude below the smallest normal becomes a zero with the sign of the exact result (flush to zero,
//    tininess after rounding); overflow gives an infinity;
//  * every NaN is the canonical quiet NaN 0x7FC00000 when encoded (to_bits);
//  * min / max are IEEE 754-2019 minimum / maximum: NaN if either operand is NaN, and -0 < +0;
//  * nothing is fused (compile with -ffp-contract=off, never -ffast-math).
//
// C simulation computes each operation as the golden model does: in double precision (exact for +, -, *
// of binary32 operands up to the final rounding, and a harmless double rounding for / and sqrt, see
// models/number_format.py), then rounds to binary32 with the flush rule above (round_ftz). The host's own
// float operations would differ from the golden in one place: a product whose exact magnitude lies in
// [2^-126 (1 - 2^-24), 2^-126 (1 - 2^-25)) rounds to 2^-126 on the host's gradual-underflow grid but flushes to
// zero under tininess after rounding (hls_export/tests/test_fp_ops.py builds such products).
// Synthesis (__SYNTHESIS__) uses plain float operators, which Vitis HLS maps to the Xilinx floating-point
// cores; those flush subnormals themselves. In a Verilator co-simulation of the export the cores are
// replaced by the rtl/fp operators (hls_export/README.md), which implement the golden rules exactly.
#ifndef PGS_FP_H
#define PGS_FP_H

#include <cmath>
#include <cstdint>

namespace pgs {

static const uint32_t kCanonicalNaN = 0x7FC00000u;

union FloatBits {
    float f;
    uint32_t u;
};

inline uint32_t raw_bits(float x) {
    FloatBits fb;
    fb.f = x;
    return fb.u;
}

inline float raw_float(uint32_t u) {
    FloatBits fb;
    fb.u = u;
    return fb.f;
}

inline bool sign_bit(float x) { return (raw_bits(x) >> 31) != 0; }
inline bool is_nan(float x) { return x != x; }

// A stored word -> value: subnormal patterns read as a signed zero.
inline float from_bits(uint32_t u) { return ((u >> 23) & 0xFFu) == 0 ? raw_float(u & 0x80000000u) : raw_float(u); }

// A value -> stored word: NaN becomes the canonical quiet NaN.
inline uint32_t to_bits(float x) { return is_nan(x) ? kCanonicalNaN : raw_bits(x); }

#ifndef __SYNTHESIS__
// Round a double-precision result to binary32 as models/number_format.py NumberFormat.round does: a value
// rounds to at least the smallest normal number iff its magnitude is at least 2^-126 (1 - 2^-25); below
// that it becomes a signed zero.
inline float round_ftz(double x) {
    static const double flush_below = std::ldexp(1.0 - std::ldexp(1.0, -25), -126);  // C++14: no hex floats
    if (std::isnan(x)) return raw_float(kCanonicalNaN);
    if (std::fabs(x) < flush_below) return std::signbit(x) ? -0.0f : 0.0f;
    return static_cast<float>(x);
}

inline float add(float a, float b) { return round_ftz(double(a) + double(b)); }
inline float sub(float a, float b) { return round_ftz(double(a) - double(b)); }
inline float mul(float a, float b) { return round_ftz(double(a) * double(b)); }
inline float div(float a, float b) { return round_ftz(double(a) / double(b)); }
inline float sqrt(float a) { return round_ftz(std::sqrt(double(a))); }
#else
inline float add(float a, float b) { return a + b; }
inline float sub(float a, float b) { return a - b; }
inline float mul(float a, float b) { return a * b; }
inline float div(float a, float b) { return a / b; }
inline float sqrt(float a) { return std::sqrt(a); }
#endif

// IEEE 754-2019 maximum / minimum (not std::fmax / fmin, which drop a NaN and may ignore zero signs).
inline float maximum(float a, float b) {
    if (is_nan(a) || is_nan(b)) return raw_float(kCanonicalNaN);
    const bool pick_a = (a > b) || (a == b && !sign_bit(a));
    return pick_a ? a : b;
}

inline float minimum(float a, float b) {
    if (is_nan(a) || is_nan(b)) return raw_float(kCanonicalNaN);
    const bool pick_a = (a < b) || (a == b && sign_bit(a));
    return pick_a ? a : b;
}

// A datapath constant: the double value rounded once to binary32 (the golden's ar.const); the constants
// used are normal numbers, for which this is the plain conversion.
inline float constant(double x) { return static_cast<float>(x); }

}  // namespace pgs

#endif  // PGS_FP_H
