// pgs_csim_main.cpp: C simulation testbench of the HLS kernel, a drop-in for the Verilator harness of the RTL
// kernel (sim/harness/pgs_kernel_main.cpp): the same command line and the same files, so that
// sim/drive/harness_run.py and sim/compare/trace_bits.py (write_inputs, run_harness, read_trace, compare_trace,
// compare_body_out) check it against the golden model unchanged.
//
// Usage: pgs_csim DIR SEED GAP_PERMILLE BP_PERMILLE MAX_CYCLES [DDR_MILLIBYTES STARTUP PROGRESS]
//   reads  DIR/regs.bin (uint32 LE {addr, value} pairs: the AXI4-Lite writes before ap_start),
//          DIR/body_in.bin + body_in_last.bin, DIR/cons.bin + cons_last.bin (beats and one TLAST byte each)
//   writes DIR/trace.bin (per retired manifold-pass: uint64 record index where the harness has the cycle, then
//          the trace record, 16 W + 64 bits), DIR/body_out.bin + body_out_last.bin, DIR/result.txt
// C simulation is untimed: SEED, GAP_PERMILLE, BP_PERMILLE, MAX_CYCLES and the DMA arguments are accepted and
// ignored, and result.txt has no cycle counters. Its keys: status, issued (the kernel's outputs at 0x58 and
// 0x78), trace_records, body_out_beats, body_in_beats_taken, cons_beats_taken, body_in_beats_left,
// cons_beats_left, cons_beats_unsent (the records design: beats the DMA did not stream because the kernel ended
// first), empty_reads (reads of an empty input stream; shims only), wall_s, hazard_window, window_hazards.
// Built with PGS_IMPULSES_IN_RECORDS = 1 the testbench plays the DMA of the records design (pgs_csim_dma.h): it also
// reads DIR/impulse_plan.bin, runs the kernel in a second thread, streams each record with the impulse buffer
// applied, and writes DIR/imp_out.bin + imp_out_last.bin (the m_axis_imp records and their TLAST) and
// impulse_out_records in result.txt. $PGS_CSIM_WAIT_S (default 60): seconds the DMA waits for an impulse-out record
// before it stops the run (exit 2) as stuck.
// The window kernel's build (PGS_WINDOW > 0) also takes lag and fetch_passes from regs.bin, and its DMA streams
// fetches of window records (impulse_plan.bin's beats per record).
// window_hazards: records that name a dynamic body also named by one of the hazard_window records before them
// in the same pipelined loop (hazard_window from $PGS_HAZARD_WINDOW, default 128): a pass of the streaming kernel, in
// slot order; a fetch of the window kernel, in its pass schedule's order (a window record's lanes count as one). The
// synthesized kernel declares the velocity dependence false (pgs_kernel.cpp), so it matches this sequential C
// simulation only when that count is 0 for a window of at least the records its pipeline holds.
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "pgs_kernel.h"
#if PGS_IMPULSES_IN_RECORDS
#if !PGS_USING_SHIMS
#error "the records design's testbench plays the DMA in a second thread: build it with -DPGS_FORCE_SHIMS"
#endif
#include "pgs_csim_dma.h"
#endif

using namespace pgs;

namespace {

[[noreturn]] void fail(const std::string& msg) {
    std::fprintf(stderr, "pgs_csim: %s\n", msg.c_str());
    std::exit(2);
}

// The harness's input files of DIR, by name (regs, body_in, body_in_last, cons, cons_last; impulse_plan for the
// records design).
std::map<std::string, std::vector<uint8_t> > read_inputs(const std::string& dir) {
    std::map<std::string, std::vector<uint8_t> > files;
    std::vector<const char*> names = {"regs", "body_in", "body_in_last", "cons", "cons_last"};
    if (kImpulsesInRecords) names.push_back("impulse_plan");
    for (const char* name : names) {
        std::ifstream f(dir + "/" + name + ".bin", std::ios::binary);
        if (!f) fail("cannot open " + dir + "/" + name + ".bin");
        files[name].assign(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
    }
    return files;
}

std::FILE* create(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) fail("cannot create " + path);
    return f;
}

// little-endian bytes <-> ap_uint<D> (D a multiple of 32)
template <int D>
ap_uint<D> from_bytes(const uint8_t* src) {
    static_assert(D % 32 == 0, "beat width must be a multiple of 32 bits");
    ap_uint<D> v;
    for (int i = 0; i < D / 32; i++) {
        uint32_t w;
        std::memcpy(&w, src + 4 * i, 4);
        v.range(32 * i + 31, 32 * i) = w;
    }
    return v;
}

template <int D>
void to_bytes(const ap_uint<D>& v, uint8_t* dst) {
    static_assert(D % 32 == 0, "beat width must be a multiple of 32 bits");
    for (int i = 0; i < D / 32; i++) {
        const uint32_t w = v.range(32 * i + 31, 32 * i).to_uint();
        std::memcpy(dst + 4 * i, &w, 4);
    }
}

template <int D>
void feed(hls::stream<ap_axiu<D, 0, 0, 0> >& s, const std::vector<uint8_t>& data, const std::vector<uint8_t>& last) {
    for (size_t i = 0; i < last.size(); i++) {
        ap_axiu<D, 0, 0, 0> beat;
        beat.data = from_bytes<D>(&data[i * (D / 8)]);
        beat.keep = all_ones<D / 8>();
        beat.strb = all_ones<D / 8>();
        beat.last = last[i] ? 1 : 0;
        s.write(beat);
    }
}

// Records that would read a velocity still in flight in a pipeline holding `window` records: fed the kernel's records
// in its order, loop by loop (the records of one loop may overlap in the pipeline, those of two never do).
class HazardCount {
  public:
    HazardCount(const std::vector<bool>& dynamic, uint32_t window)
        : dynamic_(dynamic), seen_loop_(dynamic.size(), -1), seen_at_(dynamic.size(), 0), window_(window) {}
    void next_loop() {
        loop_++;
        at_ = 0;
    }
    // the next record of the loop, its bodies (`n` of them)
    void record(const uint32_t* bodies, int n) {
        bool hazard = false;
        for (int i = 0; i < n; i++)
            if (is_dynamic(bodies[i]) && seen_loop_[bodies[i]] == loop_ && at_ - seen_at_[bodies[i]] < window_)
                hazard = true;
        for (int i = 0; i < n; i++)
            if (is_dynamic(bodies[i])) {
                seen_loop_[bodies[i]] = loop_;
                seen_at_[bodies[i]] = at_;
            }
        hazards_ += hazard;
        at_++;
    }
    uint64_t hazards() const { return hazards_; }

  private:
    bool is_dynamic(uint32_t body) const { return body < dynamic_.size() && dynamic_[body]; }
    std::vector<bool> dynamic_;
    std::vector<int64_t> seen_loop_, seen_at_;
    int64_t loop_ = 0, at_ = 0, window_;
    uint64_t hazards_ = 0;
};

// The dynamic flags of the body-in records.
std::vector<bool> dynamic_bodies(const std::vector<uint8_t>& body_in, uint32_t nb) {
    const size_t body_bytes = kBodyInBeats * kBodyInW / 8;
    std::vector<bool> dynamic(nb, false);
    for (uint32_t i = 0; i < nb && (i + 1) * body_bytes <= body_in.size(); i++)
        dynamic[i] = decode_body_in(from_bytes<kBodyInBeats * kBodyInW>(&body_in[i * body_bytes])).inv_mass != 0.0f;
    return dynamic;
}

// the body indices of the record header at byte `offset` of the constraint stream (the first beat of either kind)
void header_bodies(const std::vector<uint8_t>& cons, size_t offset, uint32_t* bodies) {
    const Header h = header_at(from_bytes<kConsW>(&cons[offset]));
    bodies[0] = h.body_a;
    bodies[1] = h.body_b;
}

#if !PGS_WINDOW
// The streaming kernel: pass after pass, the records in slot order.
uint64_t count_window_hazards(const std::vector<uint8_t>& body_in, const std::vector<uint8_t>& cons, uint32_t nb,
                              uint32_t nm, uint32_t iterations, bool interleaved, uint32_t window) {
    HazardCount count(dynamic_bodies(body_in, nb), window);
    size_t offset = 0;
    for (uint32_t p = 0; p < 2 * iterations; p++, count.next_loop()) {
        const size_t rec_bytes = (pass_is_friction(p, iterations, interleaved) ? kFrictionBeats : kContactBeats) *
                                 kConsW / 8;
        for (uint32_t k = 0; k < nm && offset + rec_bytes <= cons.size(); k++, offset += rec_bytes) {
            uint32_t bodies[2];
            header_bodies(cons, offset, bodies);
            count.record(bodies, 2);
        }
    }
    return count.hazards();
}
#else
// The window kernel: fetch after fetch, its passes' records in the order of its pass schedule (pgs_kernel.cpp
// window_passes: at time t pass k processes record t - k lag), each window record's lanes together (empty lanes
// skipped). Refused arguments count nothing.
uint64_t count_window_hazards(const std::vector<uint8_t>& body_in, const std::vector<uint8_t>& cons, uint32_t nb,
                              uint32_t nm, uint32_t iterations, uint32_t lag, uint32_t fetch_passes, uint32_t window) {
    HazardCount count(dynamic_bodies(body_in, nb), window);
    const size_t nrec = nm / kLanes, rec_bytes = size_t(kWindowRecBeats) * kConsW / 8;
    if (fetch_passes == 0 || lag == 0) return 0;
    for (uint32_t f = 0, p0 = 0; p0 < 2 * iterations; f++, p0 += fetch_passes, count.next_loop()) {
        const uint32_t np = std::min(fetch_passes, 2 * iterations - p0);
        for (size_t t = 0; nrec && t < nrec + size_t(np - 1) * lag; t++)
            for (uint32_t k = 0; k < np; k++) {
                const size_t offset = (f * nrec + t - k * size_t(lag)) * rec_bytes;
                if (t < k * size_t(lag) || t - k * size_t(lag) >= nrec || offset + rec_bytes > cons.size()) continue;
                uint32_t bodies[2 * kLanes];
                int n = 0;
                for (int l = 0; l < kLanes; l++) {
                    const size_t lane = offset + size_t(l) * kWindowBeats * kConsW / 8;
                    uint64_t header;
                    std::memcpy(&header, &cons[lane], 8);
                    if (header != ~uint64_t(0)) header_bodies(cons, lane, bodies + 2 * n++);  // not an empty lane
                }
                count.record(bodies, 2 * n);
            }
    }
    return count.hazards();
}
#endif

}  // namespace

int main(int argc, char** argv) {
    if (argc < 6) {  // the harness's arguments; only DIR matters to an untimed simulation
        std::fprintf(stderr, "usage: %s DIR SEED GAP_PERMILLE BP_PERMILLE MAX_CYCLES [...]\n", argv[0]);
        return 1;
    }
    const std::string dir = argv[1];
    const char* window_env = std::getenv("PGS_HAZARD_WINDOW");
    const uint32_t window = window_env ? uint32_t(std::strtoul(window_env, nullptr, 0)) : 128;

    std::map<std::string, std::vector<uint8_t> > in = read_inputs(dir);
    const std::vector<uint8_t>& regs = in["regs"];
    const std::vector<uint8_t>& body_in = in["body_in"];
    const std::vector<uint8_t>& body_in_last = in["body_in_last"];
    const std::vector<uint8_t>& cons = in["cons"];
    const std::vector<uint8_t>& cons_last = in["cons_last"];
    if (body_in.size() != body_in_last.size() * (kBodyInW / 8) || cons.size() != cons_last.size() * (kConsW / 8))
        fail("beat / TLAST files disagree");

    std::map<uint32_t, uint32_t> reg;
    for (size_t i = 0; i + 8 <= regs.size(); i += 8) {
        uint32_t a, v;
        std::memcpy(&a, &regs[i], 4);
        std::memcpy(&v, &regs[i + 4], 4);
        reg[a] = v;
    }
    const uint32_t nb = reg[kRegNumBodies], nm = reg[kRegNumManifolds], iters = reg[kRegIterations];
#if PGS_WINDOW  // the window kernel's arguments (the harness writes them for a window job only)
#define PGS_WINDOW_CALL reg[kRegLag], reg[kRegFetchPasses],
#else
#define PGS_WINDOW_CALL
#endif
#if PGS_SOFT_CONTACT  // the soft contact build's keep factors (the harness writes them for a soft job only)
#define PGS_SOFT_CALL reg[kRegKeepDyn], reg[kRegKeepStatic],
#else
#define PGS_SOFT_CALL
    if (reg[kRegOptions] & kOptSoftContact) fail("a soft contact job needs the build with PGS_SOFT_CONTACT=1");
#endif

    hls::stream<body_in_beat_t> s_body("s_axis_body");
    hls::stream<cons_beat_t> s_cons("s_axis_cons");
    hls::stream<body_out_beat_t> m_body("m_axis_body");
    hls::stream<trace_t> trace("trace");
    feed(s_body, body_in, body_in_last);

    uint32_t status = 0, issued = 0;
    const auto t0 = std::chrono::steady_clock::now();
#if PGS_IMPULSES_IN_RECORDS
    const char* wait_env = std::getenv("PGS_CSIM_WAIT_S");
    RecordsDma dma(in["impulse_plan"], cons, cons_last, wait_env ? std::strtod(wait_env, nullptr) : 60.0);
    if (!dma.error().empty()) fail(dma.error());
    hls::stream<imp_beat_t> m_imp("m_axis_imp");
    s_cons.open_producer();  // the DMA streams the records while the kernel runs
    m_imp.open_producer();
    std::thread kernel([&] {
        pgs_kernel(s_body, s_cons, m_body, trace, m_imp, nb, nm, iters, reg[kRegDt], reg[kRegGravityX],
                   reg[kRegGravityY], reg[kRegGravityZ], reg[kRegDamping], reg[kRegOptions], PGS_SOFT_CALL
                   PGS_WINDOW_CALL &status, &issued);
        m_imp.close_producer();
    });
    if (!dma.stream_records(s_cons, m_imp)) fail(dma.error());  // exits with the kernel thread still waiting
    kernel.join();
    dma.drain(m_imp);
    const size_t cons_fed = dma.beats_fed();
#else
    feed(s_cons, cons, cons_last);
    const size_t cons_fed = cons_last.size();
    pgs_kernel(s_body, s_cons, m_body, trace, nb, nm, iters, reg[kRegDt], reg[kRegGravityX], reg[kRegGravityY],
               reg[kRegGravityZ], reg[kRegDamping], reg[kRegOptions], PGS_SOFT_CALL &status, &issued);
#endif
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

    std::FILE* ftrace = create(dir + "/trace.bin");
    uint64_t n_trace = 0;
    uint8_t tbuf[kTraceBits / 8];
    while (!trace.empty()) {
        std::fwrite(&n_trace, 8, 1, ftrace);  // the record index stands where the RTL harness has the cycle
        to_bytes<kTraceBits>(trace.read(), tbuf);
        std::fwrite(tbuf, 1, sizeof tbuf, ftrace);
        n_trace++;
    }
    std::fclose(ftrace);

    std::FILE* fout = create(dir + "/body_out.bin");
    std::FILE* fout_last = create(dir + "/body_out_last.bin");
    uint64_t n_out = 0;
    uint8_t obuf[kBodyOutW / 8];
    while (!m_body.empty()) {
        const body_out_beat_t beat = m_body.read();
        to_bytes<kBodyOutW>(beat.data, obuf);
        std::fwrite(obuf, 1, sizeof obuf, fout);
        const uint8_t l = beat.last.to_uint() ? 1 : 0;
        std::fwrite(&l, 1, 1, fout_last);
        n_out++;
    }
    std::fclose(fout);
    std::fclose(fout_last);

#if PGS_IMPULSES_IN_RECORDS
    std::FILE* fimp = create(dir + "/imp_out.bin");
    std::fwrite(dma.imp_out().data(), 1, dma.imp_out().size(), fimp);
    std::fclose(fimp);
    std::FILE* fimp_last = create(dir + "/imp_out_last.bin");
    std::fwrite(dma.imp_out_last().data(), 1, dma.imp_out_last().size(), fimp_last);
    std::fclose(fimp_last);
#endif

#if PGS_USING_SHIMS
    const unsigned long long empty_reads = s_body.empty_reads() + s_cons.empty_reads();
#else
    const unsigned long long empty_reads = 0;
#endif
#if PGS_WINDOW
    const uint64_t hazards = count_window_hazards(body_in, cons, nb, nm, iters, reg[kRegLag], reg[kRegFetchPasses],
                                                  window);
#else
    const uint64_t hazards = count_window_hazards(body_in, cons, nb, nm, iters, (reg[kRegOptions] & kOptInterleaved) != 0,
                                                  window);
#endif
    std::FILE* fr = create(dir + "/result.txt");
    std::fprintf(fr, "status %u\nissued %u\n", status, issued);
    std::fprintf(fr, "trace_records %llu\nbody_out_beats %llu\n", (unsigned long long)n_trace,
                 (unsigned long long)n_out);
    std::fprintf(fr, "body_in_beats_taken %zu\ncons_beats_taken %zu\n", body_in_last.size() - s_body.size(),
                 cons_fed - s_cons.size());
    std::fprintf(fr, "body_in_beats_left %zu\ncons_beats_left %zu\ncons_beats_unsent %zu\nempty_reads %llu\n",
                 s_body.size(), s_cons.size(), cons_last.size() - cons_fed, empty_reads);
    std::fprintf(fr, "wall_s %.6f\nhazard_window %u\nwindow_hazards %llu\n", wall, window,
                 (unsigned long long)hazards);
#if PGS_IMPULSES_IN_RECORDS
    std::fprintf(fr, "impulse_out_records %zu\n", dma.records_out());
#endif
    std::fclose(fr);
    return 0;
}
