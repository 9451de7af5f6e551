// tangent_basis_main.cpp: the HLS kernel's tangent basis (hls_export/pgs_solver.h plane_space, the friction pass of
// the build with PGS_TANGENTS_ON_CHIP = 1) of normals from a file, for hls_export/tests/test_csim_tangents.py, which
// compares the results with models/setup/tangent_basis.py plane_space_in bit for bit.
// Usage: tangent_basis IN OUT. IN: uint32 LE triples, a normal's n_x, n_y, n_z words of the format
// (PGS_EXP_BITS / PGS_MAN_BITS); OUT: six uint32 LE words per normal, t0 xyz then t1 xyz. Words are read with
// from_bits (subnormals as signed zeros) and written with to_bits (canonical NaN).
#include <cstdint>
#include <cstdio>

#include "pgs_solver.h"

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
        const pgs::Vec3 n = {pgs::from_bits(v[0]), pgs::from_bits(v[1]), pgs::from_bits(v[2])};
        pgs::Vec3 t[2];
        pgs::plane_space(n, t);
        const uint32_t out[6] = {pgs::to_bits(t[0].x), pgs::to_bits(t[0].y), pgs::to_bits(t[0].z),
                                 pgs::to_bits(t[1].x), pgs::to_bits(t[1].y), pgs::to_bits(t[1].z)};
        std::fwrite(out, 4, 6, fout);
    }
    std::fclose(fin);
    std::fclose(fout);
    return 0;
}
