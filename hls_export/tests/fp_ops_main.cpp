// fp_ops_main.cpp: applies the HLS kernel's binary32 operations (hls_export/pgs_fp.h) to vectors, for
// hls_export/tests/test_fp_ops.py, which compares the results with models/formats/number_format.py.
// Usage: fp_ops IN OUT. IN: uint32 LE triples {op, a bits, b bits}; OUT: one uint32 LE result per triple.
// op: 0 add, 1 sub, 2 mul, 3 div, 4 sqrt (of a), 5 minimum, 6 maximum. Operands are read with from_bits
// (subnormals as signed zeros) and results written with to_bits (canonical NaN).
#include <cstdint>
#include <cstdio>
#include <vector>

#include "pgs_fp.h"

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s IN OUT\n", argv[0]);
        return 1;
    }
    std::FILE* fin = std::fopen(argv[1], "rb");
    std::FILE* fout = std::fopen(argv[2], "wb");
    if (!fin || !fout) {
        std::fprintf(stderr, "cannot open %s or %s\n", argv[1], argv[2]);
        return 2;
    }
    uint32_t v[3];
    while (std::fread(v, 4, 3, fin) == 3) {
        const float a = pgs::from_bits(v[1]), b = pgs::from_bits(v[2]);
        float r;
        switch (v[0]) {
            case 0: r = pgs::add(a, b); break;
            case 1: r = pgs::sub(a, b); break;
            case 2: r = pgs::mul(a, b); break;
            case 3: r = pgs::div(a, b); break;
            case 4: r = pgs::sqrt(a); break;
            case 5: r = pgs::minimum(a, b); break;
            case 6: r = pgs::maximum(a, b); break;
            default: std::fprintf(stderr, "unknown op %u\n", v[0]); return 3;
        }
        const uint32_t out = pgs::to_bits(r);
        std::fwrite(&out, 4, 1, fout);
    }
    std::fclose(fin);
    std::fclose(fout);
    return 0;
}
