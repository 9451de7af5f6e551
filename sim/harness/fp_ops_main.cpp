// fp_ops_main.cpp: compiled Verilator driver for fp_ops_tb (all fp operators of one format).
//
// Usage: fp_ops_sim IN.bin OUT.bin [SEED [IDLE_PERMILLE]]
//   IN.bin : N operand pairs, little-endian uint32 {a, b} (bit patterns in the low W bits);
//            "-" reads them from stdin.
//   OUT.bin: N records of 8 little-endian uint32:
//            {a+b, a-b, a*b, a/b, sqrt(a), minimum(a,b), maximum(a,b), flags}
//            with flags = {unordered, eq, lt} in bits 2..0 and the event flags {invalid, underflow,
//            overflow} of add, sub, mul, div, sqrt in bits 5..3, 8..6, 11..9, 14..12, 17..15.
// One pair is offered per cycle; with probability IDLE_PERMILLE/1000 (default 30) a cycle is
// left idle instead (in_valid = 0, random junk on the operand inputs), so valid-in/valid-out is
// exercised. Each operator's results are collected in order from its valid output, and every
// result must appear exactly LATENCY cycles after its operands; any violation, a missing or an
// extra result, or a valid output during / right after reset is an error (exit status 2).
// Prints the latencies and counts on stdout.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "Vfp_ops_tb.h"
#include "verilated.h"
#include "harness_driver.h"
#include "harness_rng.h"

namespace {

constexpr int kOps = 6;          // channels: add, sub, mul, div, sqrt, minmax
constexpr int kRecord = 8;       // uint32 words per output record
const char* const kNames[kOps] = {"add", "sub", "mul", "div", "sqrt", "minmax"};

constexpr const char* kProgram = "fp_ops_sim";

[[noreturn]] void fail(const char* msg) { harness::fail(kProgram, msg); }

}  // namespace

int main(int argc, char** argv) {
    if (argc < 3) return harness::usage(argv[0], "IN.bin|- OUT.bin [SEED [IDLE_PERMILLE]]");
    const uint64_t seed = harness::arg_or(argc, argv, 3, 1);
    const unsigned idle_permille = static_cast<unsigned>(harness::arg_or(argc, argv, 4, 30));
    const std::vector<uint32_t> in =
        harness::read_records(kProgram, argv[1], 2, "input holds an odd number of words", /*dash_is_stdin=*/true);
    const size_t n = in.size() / 2;

    auto ctx = harness::seeded_context(seed);
    auto top = std::make_unique<Vfp_ops_tb>(ctx.get(), "fp_ops_tb");
    Rng rng(seed);
    top->clk = 0;
    top->rst = 1;
    top->in_valid = 0;
    top->eval();  // settle the constant outputs (format width, latencies)

    const unsigned width = top->fmt_width;
    const uint32_t mask = width >= 32 ? 0xFFFFFFFFu : ((1u << width) - 1u);
    const unsigned lat[kOps] = {top->lat_add, top->lat_add, top->lat_mul,
                                top->lat_div, top->lat_sqrt, top->lat_minmax};
    unsigned max_lat = 0;
    for (unsigned l : lat) max_lat = l > max_lat ? l : max_lat;

    std::vector<uint32_t> out(n * kRecord, 0);
    std::vector<uint64_t> in_cycle(n, 0);
    size_t count[kOps] = {0, 0, 0, 0, 0, 0};
    uint64_t cycle = 0;

    auto tick = [&]() {
        harness::clock_cycle(*top);
        ++cycle;
    };
    auto any_valid = [&]() {
        return top->add_valid || top->sub_valid || top->mul_valid || top->div_valid ||
               top->sqrt_valid || top->mm_valid;
    };
    // Sample the registered outputs (state after the previous clock edge) at cycle `cycle`.
    auto collect = [&]() {
        const bool v[kOps] = {top->add_valid != 0, top->sub_valid != 0, top->mul_valid != 0,
                              top->div_valid != 0, top->sqrt_valid != 0, top->mm_valid != 0};
        for (int k = 0; k < kOps; ++k) {
            if (!v[k]) continue;
            const size_t idx = count[k]++;
            if (idx >= n) {
                std::fprintf(stderr, "fp_ops_sim: %s: extra result at cycle %llu\n", kNames[k],
                             static_cast<unsigned long long>(cycle));
                std::exit(2);
            }
            if (cycle - in_cycle[idx] != lat[k]) {
                std::fprintf(stderr, "fp_ops_sim: %s: result %zu after %llu cycles, LATENCY is %u\n",
                             kNames[k], idx, static_cast<unsigned long long>(cycle - in_cycle[idx]), lat[k]);
                std::exit(2);
            }
            uint32_t* rec = &out[idx * kRecord];
            switch (k) {
                case 0: rec[0] = top->add_y; rec[7] |= uint32_t(top->add_flags) << 3; break;
                case 1: rec[1] = top->sub_y; rec[7] |= uint32_t(top->sub_flags) << 6; break;
                case 2: rec[2] = top->mul_y; rec[7] |= uint32_t(top->mul_flags) << 9; break;
                case 3: rec[3] = top->div_y; rec[7] |= uint32_t(top->div_flags) << 12; break;
                case 4: rec[4] = top->sqrt_y; rec[7] |= uint32_t(top->sqrt_flags) << 15; break;
                default:
                    rec[5] = top->min_y;
                    rec[6] = top->max_y;
                    rec[7] |= top->cmp_flags;
                    break;
            }
        }
    };

    // Reset: a few cycles with junk on the inputs and in_valid high; nothing may come out.
    top->clk = 0;
    top->rst = 1;
    top->in_valid = 1;
    for (int i = 0; i < 4; ++i) {
        top->a = static_cast<uint32_t>(rng.next()) & mask;
        top->b = static_cast<uint32_t>(rng.next()) & mask;
        top->eval();
        tick();
    }
    top->rst = 0;
    top->in_valid = 0;
    top->eval();
    if (any_valid()) fail("valid output right after reset");
    cycle = 0;

    size_t next = 0;
    uint64_t idle = 0;
    const uint64_t limit = 4 * static_cast<uint64_t>(n) + max_lat + 1000;
    bool done = false;
    while (!done) {
        if (next < n && (rng.next() % 1000) >= idle_permille) {
            top->in_valid = 1;
            top->a = in[2 * next] & mask;
            top->b = in[2 * next + 1] & mask;
            in_cycle[next++] = cycle;
        } else {
            top->in_valid = 0;
            top->a = static_cast<uint32_t>(rng.next()) & mask;
            top->b = static_cast<uint32_t>(rng.next()) & mask;
            if (next < n) ++idle;
        }
        top->eval();
        collect();
        tick();
        done = next == n;
        for (int k = 0; k < kOps; ++k) done = done && count[k] == n;
        if (cycle > limit) fail("timeout waiting for results");
    }
    // Drain: no operator may produce anything more.
    top->in_valid = 0;
    for (unsigned i = 0; i < max_lat + 4; ++i) {
        top->eval();
        collect();
        tick();
    }

    harness::write_words(kProgram, argv[2], out);
    top->final();

    std::printf("latency add=%u sub=%u mul=%u div=%u sqrt=%u minmax=%u\n", lat[0], lat[1], lat[2], lat[3],
                lat[4], lat[5]);
    std::printf("vectors=%zu results=%zu,%zu,%zu,%zu,%zu,%zu cycles=%llu idle=%llu width=%u\n", n, count[0],
                count[1], count[2], count[3], count[4], count[5], static_cast<unsigned long long>(cycle),
                static_cast<unsigned long long>(idle), width);
    return 0;
}
