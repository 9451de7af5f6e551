// ap_int.h (shim): the part of Vitis HLS's ap_uint<N> that hls_export/ uses, for C simulation with g++
// where the Vitis headers are absent (hls_export/pgs_hls.h includes it only then). Not a general
// replacement: unsigned only, values held in 64-bit limbs, and just these operations:
//   ap_uint<N>(unsigned long long), to_uint(), to_uint64(), ==, !=,
//   range(hi, lo) as an rvalue (to_uint(), to_uint64(), conversion to ap_uint<M>) and as an lvalue
//   (= unsigned long long, = ap_uint<M>), for any hi >= lo inside the N bits.
#ifndef PGS_SHIM_AP_INT_H
#define PGS_SHIM_AP_INT_H

#include <cstdint>
#include <cstdio>
#include <cstdlib>

template <int N>
class ap_uint {
    static_assert(N >= 1, "ap_uint<N> needs N >= 1");

  public:
    static constexpr int kLimbs = (N + 63) / 64;

    ap_uint() { clear(); }
    ap_uint(unsigned long long v) {  // NOLINT: implicit like the real ap_uint
        clear();
        limb_[0] = v;
        trim();
    }

    // bit i (0 = least significant)
    bool bit(int i) const { return (limb_[i / 64] >> (i % 64)) & 1u; }
    void set_bit(int i, bool v) {
        const uint64_t m = uint64_t(1) << (i % 64);
        limb_[i / 64] = v ? (limb_[i / 64] | m) : (limb_[i / 64] & ~m);
    }

    // bits [lo, lo + n) as an integer, n <= 64
    uint64_t get_field(int lo, int n) const {
        uint64_t out = 0;
        for (int k = 0; k < n; k++) out |= uint64_t(bit(lo + k)) << k;
        return out;
    }
    void set_field(int lo, int n, uint64_t v) {
        for (int k = 0; k < n; k++) set_bit(lo + k, (v >> k) & 1u);
    }

    unsigned to_uint() const { return unsigned(limb_[0]); }
    unsigned long long to_uint64() const { return limb_[0]; }

    bool operator==(const ap_uint& o) const {
        for (int i = 0; i < kLimbs; i++)
            if (limb_[i] != o.limb_[i]) return false;
        return true;
    }
    bool operator!=(const ap_uint& o) const { return !(*this == o); }

    class range_ref;
    range_ref range(int hi, int lo) { return range_ref(this, hi, lo); }
    range_ref range(int hi, int lo) const { return range_ref(const_cast<ap_uint*>(this), hi, lo); }

  private:
    uint64_t limb_[kLimbs];

    void clear() {
        for (int i = 0; i < kLimbs; i++) limb_[i] = 0;
    }
    void trim() {
        if (N % 64) limb_[kLimbs - 1] &= (uint64_t(1) << (N % 64)) - 1;
    }
};

template <int N>
class ap_uint<N>::range_ref {
  public:
    range_ref(ap_uint* p, int hi, int lo) : p_(p), hi_(hi), lo_(lo) {
        if (lo < 0 || hi < lo || hi >= N) {
            std::fprintf(stderr, "ap_uint<%d>::range(%d, %d) out of bounds\n", N, hi, lo);
            std::abort();
        }
    }
    int width() const { return hi_ - lo_ + 1; }

    unsigned long long to_uint64() const { return p_->get_field(lo_, width() < 64 ? width() : 64); }
    unsigned to_uint() const { return unsigned(to_uint64()); }

    template <int M>
    operator ap_uint<M>() const {  // NOLINT: implicit like the real range reference
        ap_uint<M> out;
        for (int k = 0; k < width() && k < M; k++) out.set_bit(k, p_->bit(lo_ + k));
        return out;
    }

    range_ref& operator=(unsigned long long v) {
        for (int k = 0; k < width(); k++) p_->set_bit(lo_ + k, k < 64 && ((v >> k) & 1u));
        return *this;
    }
    template <int M>
    range_ref& operator=(const ap_uint<M>& v) {
        for (int k = 0; k < width(); k++) p_->set_bit(lo_ + k, k < M && v.bit(k));
        return *this;
    }

  private:
    ap_uint* p_;
    int hi_, lo_;
};

#endif  // PGS_SHIM_AP_INT_H
