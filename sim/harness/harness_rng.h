// harness_rng.h: the seeded random source shared by the compiled Verilator harnesses (idle cycles, junk
// data, backpressure), so that one seed reproduces a run.
#pragma once

#include <cstdint>

struct Rng {  // xorshift64*
    uint64_t s;
    explicit Rng(uint64_t seed) : s(seed ? seed : 0x9E3779B97F4A7C15ULL) {}
    uint64_t next() {
        s ^= s >> 12;
        s ^= s << 25;
        s ^= s >> 27;
        return s * 0x2545F4914F6CDD1DULL;
    }
    bool chance(unsigned permille) { return (next() >> 11) % 1000 < permille; }
};
