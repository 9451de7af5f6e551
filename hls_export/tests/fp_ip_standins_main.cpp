// fp_ip_standins_main.cpp: compiled Verilator driver for fp_ip_standins_tb (the Floating-Point Operator
// stand-ins of hls_export/fp_ip, one per operation, behind an HLS wrapper's input buffer), for
// hls_export/tests/test_fp_ip_standins.py.
//
// Usage: fp_ip_standins IN.bin OUT.bin SEED [DISABLE_PERMILLE [IDLE_PERMILLE]]
//   IN.bin : N records of 3 little-endian uint32 {a, b, compare predicate (s_axis_operation_tdata)}.
//   OUT.bin: N records of 6 little-endian uint32: the m_axis_result_tdata of add, sub, mul, div, sqrt, cmp.
// Every cycle ce (aclken) is 0 with probability DISABLE_PERMILLE/1000 (default 300); an enabled cycle offers
// the next vector (in_valid = 1) except with probability IDLE_PERMILLE/1000 (default 30), when it offers junk
// with in_valid = 0. A disabled cycle offers junk with a random in_valid (ignored by the ce'd buffer). Inputs,
// ce included, change right after the rising edge, while the clock is high (as flops on the clock drive them in
// an export), so the clock gate's latch must hold ce until the clock falls.
// Checks (any failure: message on stderr, exit status 2):
//   * latency: with E counting enabled rising edges, a vector taken by the input buffer at the edge that makes
//     E = e comes out (tvalid) right after the edge that makes E = e + 1 + (C_LATENCY - 1) = e + C_LATENCY,
//     on every channel; no tvalid at any other enabled edge, none before the first result (power-up), none
//     after the last;
//   * freeze: after a disabled edge every output (tvalid and tdata of every channel) equals its value before
//     that edge.
// Prints the latencies and the counts on stdout.
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <memory>
#include <vector>

#include "Vfp_ip_standins_tb.h"
#include "verilated.h"
#include "../../sim/harness/harness_driver.h"
#include "../../sim/harness/harness_rng.h"

namespace {

constexpr int kCh = 6;  // add, sub, mul, div, sqrt, cmp
const char* const kNames[kCh] = {"add", "sub", "mul", "div", "sqrt", "cmp"};

constexpr const char* kProgram = "fp_ip_standins";

[[noreturn]] void fail(const char* msg) { harness::fail(kProgram, msg); }

struct Snapshot {
    uint32_t valid[kCh];
    uint32_t data[kCh];
    bool operator==(const Snapshot& o) const {
        return std::memcmp(valid, o.valid, sizeof valid) == 0 && std::memcmp(data, o.data, sizeof data) == 0;
    }
};

Snapshot snap(const Vfp_ip_standins_tb& t) {
    return Snapshot{{t.add_valid, t.sub_valid, t.mul_valid, t.div_valid, t.sqrt_valid, t.cmp_valid},
                    {t.add_y, t.sub_y, t.mul_y, t.div_y, t.sqrt_y, t.cmp_y}};
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) return harness::usage(argv[0], "IN.bin OUT.bin SEED [DISABLE_PERMILLE [IDLE_PERMILLE]]");
    const uint64_t seed = std::strtoull(argv[3], nullptr, 0);
    const unsigned disable_permille = static_cast<unsigned>(harness::arg_or(argc, argv, 4, 300));
    const unsigned idle_permille = static_cast<unsigned>(harness::arg_or(argc, argv, 5, 30));

    const std::vector<uint32_t> in = harness::read_records(kProgram, argv[1], 3,
                                                           "input is not a whole number of {a, b, predicate} records");
    const size_t n = in.size() / 3;

    auto ctx = harness::seeded_context(seed);
    auto top = std::make_unique<Vfp_ip_standins_tb>(ctx.get(), "fp_ip_standins_tb");
    Rng rng(seed);

    top->clk = 0;
    top->ce = 0;
    top->in_valid = 0;
    top->eval();
    const unsigned lat[kCh] = {top->lat_add, top->lat_sub, top->lat_mul, top->lat_div, top->lat_sqrt, top->lat_cmp};
    unsigned max_lat = 0;
    for (unsigned l : lat) max_lat = l > max_lat ? l : max_lat;

    std::vector<uint32_t> out(n * kCh, 0);
    std::deque<std::pair<size_t, uint64_t>> pending[kCh];  // (vector index, E at its capture edge)
    size_t results[kCh] = {0, 0, 0, 0, 0, 0};
    size_t next = 0;
    uint64_t enabled_edges = 0, disabled_edges = 0, held_valid = 0, cycles = 0;
    uint64_t drain_left = 0;
    bool offered_valid = false;  // what the inputs hold for the coming edge
    size_t offered_index = 0;

    // drive the inputs for the coming edge (called while the clock is high, right after an edge)
    auto drive = [&]() {
        const bool en = !rng.chance(disable_permille);
        top->ce = en;
        offered_valid = false;
        if (en && next < n && !rng.chance(idle_permille)) {
            offered_valid = true;
            offered_index = next++;
            top->in_valid = 1;
            top->a = in[3 * offered_index];
            top->b = in[3 * offered_index + 1];
            top->pred = static_cast<uint8_t>(in[3 * offered_index + 2]);
        } else {
            top->in_valid = en ? 0 : static_cast<uint8_t>(rng.next() & 1);
            top->a = static_cast<uint32_t>(rng.next());
            top->b = static_cast<uint32_t>(rng.next());
            top->pred = static_cast<uint8_t>(rng.next());
        }
        top->eval();
    };

    drive();
    while (true) {
        const bool en = top->ce != 0;
        const bool took = offered_valid;
        const Snapshot before = snap(*top);
        top->clk = 0;
        top->eval();
        top->clk = 1;
        top->eval();
        ++cycles;
        const Snapshot after = snap(*top);
        if (!en) {
            ++disabled_edges;
            if (!(after == before)) {
                std::fprintf(stderr, "fp_ip_standins: outputs changed at disabled edge (cycle %llu)\n",
                             static_cast<unsigned long long>(cycles));
                return 2;
            }
            for (int k = 0; k < kCh; ++k) held_valid += after.valid[k] != 0;
        } else {
            ++enabled_edges;
            if (took)
                for (int k = 0; k < kCh; ++k) pending[k].emplace_back(offered_index, enabled_edges);
            for (int k = 0; k < kCh; ++k) {
                const bool due = !pending[k].empty() && pending[k].front().second + lat[k] == enabled_edges;
                if (after.valid[k] && !due) {
                    std::fprintf(stderr, "fp_ip_standins: %s: tvalid at enabled edge %llu with no result due\n",
                                 kNames[k], static_cast<unsigned long long>(enabled_edges));
                    return 2;
                }
                if (!after.valid[k] && due) {
                    std::fprintf(stderr, "fp_ip_standins: %s: vector %zu not out %u enabled cycles after its capture\n",
                                 kNames[k], pending[k].front().first, lat[k]);
                    return 2;
                }
                if (due) {
                    out[pending[k].front().first * kCh + k] = after.data[k];
                    pending[k].pop_front();
                    ++results[k];
                }
            }
        }
        bool empty = next == n;
        for (int k = 0; k < kCh; ++k) empty = empty && pending[k].empty();
        if (empty) {
            // a few more enabled edges with nothing offered must bring no tvalid
            if (drain_left == 0) drain_left = 2 * max_lat + 8;
            if (--drain_left == 0) break;
        }
        if (cycles > 20 * (n + 100) + 1000) fail("timeout");
        drive();
    }

    for (int k = 0; k < kCh; ++k)
        if (results[k] != n) fail("a channel returned fewer results than vectors");
    harness::write_words(kProgram, argv[2], out);

    std::printf("latencies");
    for (int k = 0; k < kCh; ++k) std::printf(" %s=%u", kNames[k], lat[k]);
    std::printf("\nvectors=%zu results=%zu cycles=%llu enabled=%llu disabled=%llu held_valid_checks=%llu\n", n,
                results[0], static_cast<unsigned long long>(cycles), static_cast<unsigned long long>(enabled_edges),
                static_cast<unsigned long long>(disabled_edges), static_cast<unsigned long long>(held_valid));
    return 0;
}
