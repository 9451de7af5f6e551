// pipe_main.cpp: compiled Verilator driver for one generated kernel datapath (rtl/pgs_*_pipe.sv).
//
// Build-time macros (-CFLAGS -D...): PIPE_CLASS (the Verilated class, e.g. Vpgs_contact_pipe),
// N_IN, N_OUT (words of in_data / out_data), FMT_W (format width), HAS_SPIN_DAMP (0/1: the module
// has the in_spin_damp port), HAS_KIND (0/1: a shared datapath, rtl/gen/shared_emit.py: the in_kind and
// out_kind ports).
//
// Usage: pipe_sim IN.bin OUT.bin LATENCY [SEED [IDLE_PERMILLE]]
//   IN.bin : N records of N_IN + 1 little-endian uint32: the N_IN words (bit patterns in the low
//            FMT_W bits) and a flags word (bit 0: in_spin_damp, bit 1: in_count, bit 2: in_kind).
//   OUT.bin: N records of N_OUT little-endian uint32 (out_data words).
// One record is offered per cycle; with probability IDLE_PERMILLE/1000 (default 50) a cycle is
// left idle instead (in_valid = 0, random junk on every input). The tag of record i is i (with a
// random upper half); every output must carry the tag of the next expected record and appear
// exactly LATENCY cycles after it went in (a shared datapath's with its kind on out_kind). Any violation, a missing or extra output, or a valid
// output during / right after reset is an error (exit status 2). Prints counts on stdout, with the
// floating-point events summed over every cycle: "events=OVERFLOW,UNDERFLOW,INVALID".
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#define PIPE_STR2(x) #x
#define PIPE_STR(x) PIPE_STR2(x)
#include PIPE_STR(PIPE_CLASS.h)
#include "verilated.h"
#include "../../sim/harness/harness_driver.h"
#include "../../sim/harness/harness_rng.h"

namespace {

constexpr int kInRec = N_IN + 1;

constexpr const char* kProgram = "pipe_sim";

[[noreturn]] void fail(const char* msg) { harness::fail(kProgram, msg); }

// Write / read `width` (<= 32) bits at bit position `pos` of a little-endian word array.
void put_bits(uint32_t* words, unsigned pos, unsigned width, uint32_t value) {
    for (unsigned b = 0; b < width; ++b) {
        const unsigned p = pos + b;
        const uint32_t bit = (value >> b) & 1u;
        words[p / 32] = (words[p / 32] & ~(1u << (p % 32))) | (bit << (p % 32));
    }
}

uint32_t get_bits(const uint32_t* words, unsigned pos, unsigned width) {
    uint32_t v = 0;
    for (unsigned b = 0; b < width; ++b) {
        const unsigned p = pos + b;
        v |= ((words[p / 32] >> (p % 32)) & 1u) << b;
    }
    return v;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 4) return harness::usage(argv[0], "IN.bin OUT.bin LATENCY [SEED [IDLE_PERMILLE]]");
    const uint64_t latency = std::strtoull(argv[3], nullptr, 0);
    const uint64_t seed = harness::arg_or(argc, argv, 4, 1);
    const unsigned idle_permille = static_cast<unsigned>(harness::arg_or(argc, argv, 5, 50));
    const std::vector<uint32_t> in =
        harness::read_records(kProgram, argv[1], kInRec, "input is not a whole number of records");
    const size_t n = in.size() / kInRec;
    const uint32_t mask = FMT_W >= 32 ? 0xFFFFFFFFu : ((1u << FMT_W) - 1u);
    const uint64_t tag_hi = (seed * 0x9E3779B97F4A7C15ULL) & 0xFFFFFFFF00000000ULL;

    auto ctx = harness::seeded_context(seed);
    auto top = std::make_unique<PIPE_CLASS>(ctx.get(), "pipe");
    Rng rng(seed);
    uint32_t* in_words = top->in_data.data();
    const uint32_t* out_words = top->out_data.data();

    std::vector<uint32_t> out(n * N_OUT, 0);
    std::vector<uint64_t> in_cycle(n, 0);
    size_t count = 0;
    uint64_t cycle = 0;

    auto junk = [&]() {
        for (int k = 0; k < N_IN; ++k) put_bits(in_words, k * FMT_W, FMT_W, static_cast<uint32_t>(rng.next()) & mask);
        top->in_tag = rng.next();
        top->in_count = rng.next() & 1u;
#if HAS_SPIN_DAMP
        top->in_spin_damp = rng.next() & 1u;
#endif
#if HAS_KIND
        top->in_kind = rng.next() & 1u;
#endif
    };
    auto tick = [&]() {
        harness::clock_cycle(*top);
        ++cycle;
    };
    uint64_t events[3] = {0, 0, 0};
    auto collect = [&]() {
        events[0] += top->ev_overflow;
        events[1] += top->ev_underflow;
        events[2] += top->ev_invalid;
        if (!top->out_valid) return;
        const size_t idx = count++;
        if (idx >= n) {
            std::fprintf(stderr, "pipe_sim: extra output at cycle %llu\n", static_cast<unsigned long long>(cycle));
            std::exit(2);
        }
        if (cycle - in_cycle[idx] != latency) {
            std::fprintf(stderr, "pipe_sim: output %zu after %llu cycles, LATENCY is %llu\n", idx,
                         static_cast<unsigned long long>(cycle - in_cycle[idx]),
                         static_cast<unsigned long long>(latency));
            std::exit(2);
        }
        if (top->out_tag != (tag_hi | idx)) {
            std::fprintf(stderr, "pipe_sim: output %zu carries tag 0x%llx, expected 0x%llx\n", idx,
                         static_cast<unsigned long long>(top->out_tag),
                         static_cast<unsigned long long>(tag_hi | idx));
            std::exit(2);
        }
#if HAS_KIND
        if (top->out_kind != ((in[idx * kInRec + N_IN] >> 2) & 1u)) {
            std::fprintf(stderr, "pipe_sim: output %zu leaves with kind %u, it went in with the other\n", idx,
                         static_cast<unsigned>(top->out_kind));
            std::exit(2);
        }
#endif
        for (int k = 0; k < N_OUT; ++k) out[idx * N_OUT + k] = get_bits(out_words, k * FMT_W, FMT_W);
    };

    // Reset with in_valid high and junk inputs for a few cycles: nothing may come out.
    top->clk = 0;
    top->rst = 1;
    top->in_valid = 1;
    for (int i = 0; i < 4; ++i) {
        junk();
        top->eval();
        if (top->out_valid) fail("valid output during reset");
        tick();
    }
    top->rst = 0;
    top->in_valid = 0;
    top->eval();
    if (top->out_valid) fail("valid output right after reset");
    if (top->ev_overflow || top->ev_underflow || top->ev_invalid) fail("events right after reset");
    cycle = 0;

    size_t next = 0;
    uint64_t idle = 0;
    const uint64_t limit = 4 * static_cast<uint64_t>(n) + latency + 1000;
    while (next < n || count < n) {
        if (next < n && (rng.next() % 1000) >= idle_permille) {
            const uint32_t* rec = &in[next * kInRec];
            top->in_valid = 1;
            for (int k = 0; k < N_IN; ++k) put_bits(in_words, k * FMT_W, FMT_W, rec[k] & mask);
            top->in_tag = tag_hi | next;
            top->in_count = (rec[N_IN] >> 1) & 1u;
#if HAS_SPIN_DAMP
            top->in_spin_damp = rec[N_IN] & 1u;
#endif
#if HAS_KIND
            top->in_kind = (rec[N_IN] >> 2) & 1u;
#endif
            in_cycle[next++] = cycle;
        } else {
            top->in_valid = 0;
            junk();
            if (next < n) ++idle;
        }
        top->eval();
        collect();
        tick();
        if (cycle > limit) fail("timeout waiting for outputs");
    }
    // Drain: nothing more may come out.
    top->in_valid = 0;
    for (uint64_t i = 0; i < latency + 4; ++i) {
        junk();
        top->eval();
        collect();
        tick();
    }

    harness::write_words(kProgram, argv[2], out);
    top->final();
    std::printf("vectors=%zu outputs=%zu cycles=%llu idle=%llu latency=%llu events=%llu,%llu,%llu\n", n, count,
                static_cast<unsigned long long>(cycle), static_cast<unsigned long long>(idle),
                static_cast<unsigned long long>(latency), static_cast<unsigned long long>(events[0]),
                static_cast<unsigned long long>(events[1]), static_cast<unsigned long long>(events[2]));
    return 0;
}
