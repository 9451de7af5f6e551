// pgs_fp.h: the arithmetic of the kernel in its number format (PGS_EXP_BITS exponent and PGS_MAN_BITS mantissa
// bits, as the RTL's EXP_BITS / MAN_BITS: binary32 8/23 by default, binary16 5/10, bfloat16 8/7), with the rules of
// the golden model (models/formats/number_format.py, whose module docstring is the contract; rtl/fp implements the same):
//
//  * inputs: a subnormal bit pattern reads as a zero of its sign (from_bits);
//  * every +, -, *, /, sqrt is rounded once, to nearest even, with an unbounded exponent; a rounded
//    magnitude below the smallest normal becomes a zero with the sign of the exact result (flush to zero,
//    tininess after rounding); overflow gives an infinity;
//  * every NaN is the canonical quiet NaN (sign 0, exponent all ones, mantissa MSB 1) when encoded (to_bits);
//  * min / max are IEEE 754-2019 minimum / maximum: NaN if either operand is NaN, and -0 < +0;
//  * nothing is fused (compile with -ffp-contract=off, never -ffast-math).
//
// A value of the format is held in a C++ float (exact: at most 8 exponent and 23 mantissa bits). C simulation
// computes each operation as the golden model does: in double precision (exact for +, -, * of the format's
// operands up to the final rounding, and a harmless double rounding for / and sqrt, see models/formats/number_format.py),
// then rounds to the format with the flush rule above (round_ftz, the golden's round_bitwise on the double's bits).
// The host's own float operations would differ from the golden in binary32 in one place: a product whose exact
// magnitude lies in [2^-126 (1 - 2^-24), 2^-126 (1 - 2^-25)) rounds to 2^-126 on the host's gradual-underflow grid
// but flushes to zero under tininess after rounding (hls_export/tests/test_fp_ops.py builds such products).
// Synthesis (__SYNTHESIS__) uses plain float operators, which Vitis HLS maps to the Xilinx floating-point
// cores; those flush subnormals themselves. In a Verilator co-simulation of the export the cores are
// replaced by the rtl/fp operators (hls_export/README.md), which implement the golden rules exactly. Synthesis is
// binary32 only: another format stops it with an #error (its operators would need Vitis's half / ap_float types).
#ifndef PGS_FP_H
#define PGS_FP_H

#include <cmath>
#include <cstdint>
#include <cstring>

#ifndef PGS_EXP_BITS
#define PGS_EXP_BITS 8
#endif
#ifndef PGS_MAN_BITS
#define PGS_MAN_BITS 23
#endif

namespace pgs {

constexpr int kExpBits = PGS_EXP_BITS;
constexpr int kManBits = PGS_MAN_BITS;
static_assert(kExpBits >= 2 && kExpBits <= 8 && kManBits >= 1 && kManBits <= 23,
              "the format must fit a float: 2..8 exponent bits, 1..23 mantissa bits");
constexpr int kFormatBits = 1 + kExpBits + kManBits;  // W, the bits of a stored word
constexpr bool kBinary32 = kExpBits == 8 && kManBits == 23;
constexpr int kBias = (1 << (kExpBits - 1)) - 1;
constexpr uint32_t kExpAll = (1u << kExpBits) - 1;
constexpr uint32_t kManMask = (1u << kManBits) - 1;
constexpr uint32_t kSignBit = 1u << (kExpBits + kManBits);
static const uint32_t kCanonicalNaN = (kExpAll << kManBits) | (1u << (kManBits - 1));  // of the format
static const uint32_t kFloatNaN = 0x7FC00000u;

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

// A stored word (W bits) -> value: subnormal patterns read as a signed zero.
inline float from_bits(uint32_t u) {
    const uint32_t sign = (u & kSignBit) ? 0x80000000u : 0u;
    const uint32_t e = (u >> kManBits) & kExpAll, frac = u & kManMask;
    if (e == 0) return raw_float(sign);
    const uint32_t fe = e == kExpAll ? 0xFFu : e - kBias + 127;  // a normal number of the format is normal in float
    return raw_float(sign | (fe << 23) | (frac << (23 - kManBits)));
}

// A value of the format -> stored word: NaN becomes the canonical quiet NaN.
inline uint32_t to_bits(float x) {
    if (is_nan(x)) return kCanonicalNaN;
    const uint32_t b = raw_bits(x), sign = (b >> 31) ? kSignBit : 0u, fe = (b >> 23) & 0xFFu;
    const uint32_t frac = (b & 0x7FFFFFu) >> (23 - kManBits);
    if (fe == 0) return sign;
    const uint32_t e = fe == 0xFFu ? kExpAll : fe - 127 + kBias;
    return sign | (e << kManBits) | frac;
}

#ifndef __SYNTHESIS__
// Round a double-precision result to the format as models/formats/number_format.py NumberFormat.round_bitwise does: round
// the double's significand to kManBits bits (nearest, ties to even) with an unbounded exponent, then a magnitude
// below the smallest normal becomes a zero of the result's sign and one above the largest finite an infinity.
inline float round_ftz(double x) {
    if (std::isnan(x)) return raw_float(kFloatNaN);
    uint64_t bits;
    std::memcpy(&bits, &x, 8);
    const uint64_t sign = bits & (uint64_t(1) << 63), mag = bits & ~(uint64_t(1) << 63);
    const bool negative = sign != 0;
    if (mag >= (uint64_t(0x7FF) << 52)) return negative ? -INFINITY : INFINITY;
    const int shift = 52 - kManBits;
    const uint64_t lsb = (mag >> shift) & 1u, half_minus_one = (uint64_t(1) << (shift - 1)) - 1;
    const uint64_t mag_r = (mag + half_minus_one + lsb) & ~((uint64_t(1) << shift) - 1);
    const int exp = int(mag_r >> 52) - 1023;
    if (exp < 1 - kBias) return negative ? -0.0f : 0.0f;
    if (exp > kBias) return negative ? -INFINITY : INFINITY;
    const uint64_t r = sign | mag_r;
    double d;
    std::memcpy(&d, &r, 8);
    return static_cast<float>(d);  // exact: a value of the format
}

inline float add(float a, float b) { return round_ftz(double(a) + double(b)); }
inline float sub(float a, float b) { return round_ftz(double(a) - double(b)); }
inline float mul(float a, float b) { return round_ftz(double(a) * double(b)); }
inline float div(float a, float b) { return round_ftz(double(a) / double(b)); }
inline float sqrt(float a) { return round_ftz(std::sqrt(double(a))); }
#else
static_assert(kBinary32, "synthesis of the HLS kernel is binary32 only (plain float operators)");
inline float add(float a, float b) { return a + b; }
inline float sub(float a, float b) { return a - b; }
inline float mul(float a, float b) { return a * b; }
inline float div(float a, float b) { return a / b; }
inline float sqrt(float a) { return std::sqrt(a); }
#endif

// IEEE 754-2019 maximum / minimum (not std::fmax / fmin, which drop a NaN and may ignore zero signs).
inline float maximum(float a, float b) {
    if (is_nan(a) || is_nan(b)) return raw_float(kFloatNaN);
    const bool pick_a = (a > b) || (a == b && !sign_bit(a));
    return pick_a ? a : b;
}

inline float minimum(float a, float b) {
    if (is_nan(a) || is_nan(b)) return raw_float(kFloatNaN);
    const bool pick_a = (a < b) || (a == b && sign_bit(a));
    return pick_a ? a : b;
}

// A datapath constant: the double value rounded once to the format (the golden's ar.const).
#ifndef __SYNTHESIS__
inline float constant(double x) { return round_ftz(x); }
#else
inline float constant(double x) { return static_cast<float>(x); }  // binary32: the constants are normal numbers
#endif

}  // namespace pgs

#endif  // PGS_FP_H
