// harness_driver.h: what the compiled operator and datapath drivers share (sim/harness/fp_ops_main.cpp,
// cocotb_tests/pipes/pipe_main.cpp, hls_export/tests/fp_ip_standins_main.cpp): the failure exit, the
// little-endian uint32 word files they read and write, the command-line arguments, the clock cycle and the
// seeded Verilator context.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <vector>

#include "verilated.h"

namespace harness {

// "PROGRAM: MESSAGE" on stderr, exit status 2.
[[noreturn]] inline void fail(const char* program, const char* msg) {
    std::fprintf(stderr, "%s: %s\n", program, msg);
    std::exit(2);
}

// Every word of the file at `path`; with `dash_is_stdin`, the path "-" reads standard input.
inline std::vector<uint32_t> read_words(const char* program, const char* path, bool dash_is_stdin = false) {
    std::FILE* f = dash_is_stdin && std::strcmp(path, "-") == 0 ? stdin : std::fopen(path, "rb");
    if (!f) fail(program, "cannot open input");
    std::vector<uint32_t> data;
    uint32_t buf[8192];
    size_t got;
    while ((got = std::fread(buf, sizeof(uint32_t), 8192, f)) > 0) data.insert(data.end(), buf, buf + got);
    if (f != stdin) std::fclose(f);
    return data;
}

// The words of `path` (as read_words), which must be whole records of `record_words`: else fail with
// `not_whole`.
inline std::vector<uint32_t> read_records(const char* program, const char* path, size_t record_words,
                                          const char* not_whole, bool dash_is_stdin = false) {
    std::vector<uint32_t> data = read_words(program, path, dash_is_stdin);
    if (data.size() % record_words != 0) fail(program, not_whole);
    return data;
}

inline void write_words(const char* program, const char* path, const std::vector<uint32_t>& words) {
    std::FILE* f = std::fopen(path, "wb");
    if (!f) fail(program, "cannot open output");
    if (!words.empty() && std::fwrite(words.data(), sizeof(uint32_t), words.size(), f) != words.size())
        fail(program, "short write");
    std::fclose(f);
}

// "usage: PROGRAM ARGS" on stderr; the exit status of a call with too few arguments.
inline int usage(const char* argv0, const char* args) {
    std::fprintf(stderr, "usage: %s %s\n", argv0, args);
    return 1;
}

// Argument `i` as an unsigned number (decimal, 0x hex or 0 octal), `fallback` where it is not given.
inline uint64_t arg_or(int argc, char** argv, int i, uint64_t fallback) {
    return argc > i ? std::strtoull(argv[i], nullptr, 0) : fallback;
}

// One whole clock cycle of a Verilated model with a `clk` input: the rising edge, then the falling edge.
template <class Model>
void clock_cycle(Model& top) {
    top.clk = 1;
    top.eval();
    top.clk = 0;
    top.eval();
}

// A Verilator context whose random initial values follow `seed`, so that one seed reproduces a run.
inline std::unique_ptr<VerilatedContext> seeded_context(uint64_t seed) {
    auto ctx = std::make_unique<VerilatedContext>();
    ctx->randSeed(static_cast<int>(seed & 0x7fffffff));
    return ctx;
}

}  // namespace harness
