// pgs_kernel_main.cpp: compiled Verilator harness of rtl/pgs_kernel.sv (one step of the kernel).
//
// Usage: pgs_kernel_sim DIR SEED GAP_PERMILLE BP_PERMILLE MAX_CYCLES [DDR_MILLIBYTES STARTUP PROGRESS CLOCK_PS]
//   DIR/regs.bin        uint32 LE pairs {addr, value}: AXI4-Lite writes done before ap_start
//   DIR/body_in.bin     body-in beats (BODY_IN_BYTES each), DIR/body_in_last.bin one TLAST byte per beat
//   DIR/cons.bin        constraint beats (CONS_BYTES each),  DIR/cons_last.bin   one TLAST byte per beat
// Writes DIR/trace.bin (per retired manifold-pass: uint64 cycle, then TRACE_BYTES of trace_data; a kernel
// built with LANES > 1 retires up to LANES records a cycle, written lane by lane),
// DIR/body_out.bin + DIR/body_out_last.bin (the m_axis_body beats and their TLAST) and DIR/result.txt
// (key value lines: the kernel's status/counter registers read over AXI4-Lite after the interrupt --
// ap_ctrl, isr, status, cycles, stalls, bubbles, issued, rejected, fp_overflow, fp_underflow, fp_invalid,
// fp_status (rtl/README.md) -- then the harness's own cycle count and wall time).
// Stimulus: after reset the harness writes the registers, GIE = 1, IER = 1 (ap_done) and AP_CTRL = 1;
// it then offers stream beats with a random gap before each new beat (probability GAP_PERMILLE/1000
// per cycle; TVALID stays up until the handshake, as AXI4-Stream demands) and deasserts
// m_axis_body_TREADY with probability BP_PERMILLE/1000 per cycle, until `interrupt` rises. Exceeding
// MAX_CYCLES is a failure (exit 3) with a message naming what was still pending.
// DMA model (models/timing/platforms.py presets): DDR_MILLIBYTES is the DDR bandwidth in 1/1000 bytes per kernel
// cycle (0: uncapped), a token bucket shared by all three streams (refilled every cycle, capped at two
// constraint beats, spent when a beat is offered or accepted), the same model as the cocotb DdrBandwidth;
// STARTUP is the start-up latency of each MM2S transfer: the body-in transfer and each pass's constraint
// transfer (one per pass, as the host issues them) wait STARTUP cycles before their first beat. With
// PROGRESS > 0 a line "progress CYCLE TRACE_RECORDS" goes to stdout every PROGRESS cycles.
// Impulses in the records (built with IMPULSES_IN_RECORDS=1; IMP_OUT_BYTES, WORD_BITS, CONTACT_BEATS, FRICTION_BEATS,
// CONTACT_LAM_BIT, FRICTION_LAM_BIT, FRICTION_LAMT_BIT from models/kernel/stream_format.py): DIR/impulse_plan.bin holds
// uint32 records per block, uint32 TURNAROUND, uint32 beats per record (0: CONTACT_BEATS or FRICTION_BEATS by the
// block's kind), then one byte per block (0 contact, 1 friction). A block is a pass of the streaming kernel, a fetch
// of the window kernel (its records hold LANES lane records of equal beats; an impulse-out record holds the LANES
// lanes' 4 words). The harness keeps the DDR impulse buffer (lam[4], lamT[2] per slot): every m_axis_imp record
// (TREADY with the BP_PERMILLE backpressure) writes its block's field of its slots (contact lam, friction lamT); a
// record of a later block carries the buffer's words in place of those cons.bin holds (the host-given impulses the
// step starts from) for every field an earlier block of the step wrote. Read after write: record k of block p > 0
// is offered no earlier than TURNAROUND cycles after block p - 1's impulse-out record k was taken (the write's path
// to DDR and the read's back; every block reads what its predecessor wrote or older). The DDR bucket's rate is the
// read share the host reserved (sim/drive/harness_run.py); the impulse writes do not spend from it. Writes
// DIR/imp_out.bin (the records).
// Waveforms: built with --trace-fst (VM_TRACE), the harness writes an FST to $PGS_WAVES (when set) for the first
// $PGS_WAVE_CYCLES cycles (default 20000; 0 = the whole run). Its time is in ps (the model's time precision, checked):
// cycle N's falling edge at N * CLOCK_PS, its rising edge CLOCK_PS / 2 later (CLOCK_PS: the platform's clock period,
// default 1000). Beside it, <$PGS_WAVES without .fst>.phases lists "clock_ps P", "start C" (the cycle ap_start is
// written) and "NAME C" for each cycle C at which the sequencer enters phase NAME (LOAD SOLVE DRAIN INTEG DONE IDLE;
// the waves build makes pgs_sequencer.phase readable, sim/harness/pgs_kernel_waves.vlt).
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "Vpgs_kernel.h"
#if VM_TRACE
#include "Vpgs_kernel___024root.h"
#endif
#include "verilated.h"
#if VM_TRACE
#include "verilated_fst_c.h"
#endif
#include "harness_rng.h"

#ifndef IMPULSES_IN_RECORDS
#define IMPULSES_IN_RECORDS 0
#endif

#ifndef LANES
#define LANES 1
#endif
#ifndef BODY_IN_BYTES
#error "define BODY_IN_BYTES, CONS_BYTES, BODY_OUT_BYTES, TRACE_BYTES"
#endif

namespace {

[[noreturn]] void fail(const std::string& msg, int code = 2) {
    std::fprintf(stderr, "pgs_kernel_sim: %s\n", msg.c_str());
    std::exit(code);
}

std::vector<uint8_t> read_file(const std::string& path) {
    std::FILE* f = std::fopen(path.c_str(), "rb");
    if (!f) fail("cannot open " + path);
    std::vector<uint8_t> data;
    uint8_t buf[65536];
    size_t got;
    while ((got = std::fread(buf, 1, sizeof buf, f)) > 0) data.insert(data.end(), buf, buf + got);
    std::fclose(f);
    return data;
}

template <std::size_t N>
void set_wide(VlWide<N>& w, const uint8_t* src, size_t nbytes) {
    for (size_t i = 0; i < N; i++) {
        uint32_t v = 0;
        for (size_t b = 0; b < 4 && 4 * i + b < nbytes; b++) v |= uint32_t(src[4 * i + b]) << (8 * b);
        w[i] = v;
    }
}
template <std::size_t N>
void get_wide(const VlWide<N>& w, uint8_t* dst, size_t nbytes) {
    for (size_t i = 0; i < nbytes; i++) dst[i] = uint8_t(w[i / 4] >> (8 * (i % 4)));
}
// a port Verilator keeps in a plain integer (at most 64 bits)
template <typename T>
void get_wide(const T& w, uint8_t* dst, size_t nbytes) {
    for (size_t i = 0; i < nbytes; i++) dst[i] = uint8_t(uint64_t(w) >> (8 * i));
}

#if IMPULSES_IN_RECORDS
// `nbits` (<= 64) little-endian bits at bit `pos` of a byte array
uint64_t get_bits(const uint8_t* p, size_t pos, unsigned nbits) {
    uint64_t v = 0;
    for (unsigned i = 0; i < nbits; i++) v |= uint64_t((p[(pos + i) / 8] >> ((pos + i) % 8)) & 1u) << i;
    return v;
}
void set_bits(uint8_t* p, size_t pos, unsigned nbits, uint64_t v) {
    for (unsigned i = 0; i < nbits; i++) {
        const size_t b = pos + i;
        p[b / 8] = uint8_t((p[b / 8] & ~(1u << (b % 8))) | (((v >> i) & 1u) << (b % 8)));
    }
}

// The DDR impulse buffer and the read-after-write rule across passes (see the header comment).
struct ImpulseBuffer {
    size_t slots = 0;                           // records per block (a record holds LANES slots)
    unsigned turnaround = 1;
    size_t record_beats = 0;                    // 0: by the block's kind
    std::vector<uint8_t> kinds;                 // per block
    std::vector<size_t> rec_first;              // per record of the stream: its first beat
    std::vector<uint64_t> lam, lamT;            // 4 and 2 words per slot (record * LANES + lane)
    std::vector<uint8_t> have_lam, have_lamT;   // per record: written by a block of this step
    std::vector<int64_t> written_pass;          // per record: the last block whose record was taken, -1 none
    std::vector<uint64_t> written_at;           // and the harness cycle it was taken
    size_t n_out = 0;                           // impulse-out records taken
    std::vector<uint8_t> rec;                   // the record being offered, patched
    size_t rec_index = ~size_t(0);

    size_t beats_of(size_t block) const {
        return record_beats ? record_beats : kinds[block] ? FRICTION_BEATS : CONTACT_BEATS;
    }
    void load(const std::vector<uint8_t>& plan, size_t n_cons) {
        if (plan.size() < 12) fail("impulse_plan.bin: too short");
        uint32_t s32, t32, b32;
        std::memcpy(&s32, &plan[0], 4);
        std::memcpy(&t32, &plan[4], 4);
        std::memcpy(&b32, &plan[8], 4);
        slots = s32;
        turnaround = t32 ? t32 : 1;
        record_beats = b32;
        if (record_beats % LANES) fail("impulse_plan.bin: record beats not a multiple of the lanes");
        kinds.assign(plan.begin() + 12, plan.end());
        size_t beat = 0;
        for (size_t p = 0; p < kinds.size(); p++)
            for (size_t s = 0; s < slots; s++) {
                rec_first.push_back(beat);
                beat += beats_of(p);
            }
        if (beat != n_cons) fail("constraint stream does not match impulse_plan.bin");
        lam.assign(4 * LANES * slots, 0);
        lamT.assign(2 * LANES * slots, 0);
        have_lam.assign(slots, 0);
        have_lamT.assign(slots, 0);
        written_pass.assign(slots, -1);
        written_at.assign(slots, 0);
    }
    // record index of constraint beat `ci` (beats in order), or ~0 when not a record's first beat
    size_t first_of(size_t ci) const {
        const size_t r = rec_index == ~size_t(0) ? 0 : rec_index + 1;
        return r < rec_first.size() && rec_first[r] == ci ? r : ~size_t(0);
    }
    // may record r's first beat be offered in harness cycle `now`?
    bool readable(size_t r, uint64_t now) const {
        const size_t pass = r / slots, slot = r % slots;
        if (pass == 0) return true;
        return written_pass[slot] >= int64_t(pass) - 1 && now >= written_at[slot] + turnaround;
    }
    // the beats of record r with the buffer's impulses patched in (lane l's record at l * beats / LANES beats)
    void compose(size_t r, const std::vector<uint8_t>& cons) {
        const size_t pass = r / slots, slot = r % slots, beats = beats_of(pass);
        rec.assign(cons.begin() + rec_first[r] * CONS_BYTES, cons.begin() + (rec_first[r] + beats) * CONS_BYTES);
        const size_t lam_bit = kinds[pass] ? FRICTION_LAM_BIT : CONTACT_LAM_BIT;
        for (size_t l = 0; l < LANES; l++) {
            const size_t base = l * beats / LANES * CONS_BYTES * 8, k = slot * LANES + l;
            if (have_lam[slot])
                for (unsigned w = 0; w < 4; w++)
                    set_bits(rec.data(), base + lam_bit + w * WORD_BITS, WORD_BITS, lam[4 * k + w]);
            if (kinds[pass] && have_lamT[slot])
                for (unsigned w = 0; w < 2; w++)
                    set_bits(rec.data(), base + FRICTION_LAMT_BIT + w * WORD_BITS, WORD_BITS, lamT[2 * k + w]);
        }
        rec_index = r;
    }
    const uint8_t* beat(size_t ci) const { return &rec[(ci - rec_first[rec_index]) * CONS_BYTES]; }
    // an impulse-out record taken in harness cycle `now` (lane l's 4 words at bit 4 * l * WORD_BITS)
    void write(const uint8_t* data, uint64_t now) {
        const size_t pass = n_out / slots, slot = n_out % slots;
        if (pass >= kinds.size()) fail("more impulse-out records than the blocks have records");
        for (size_t l = 0; l < LANES; l++) {
            const size_t k = slot * LANES + l, base = 4 * l * WORD_BITS;
            if (kinds[pass])
                for (unsigned w = 0; w < 2; w++) lamT[2 * k + w] = get_bits(data, base + w * WORD_BITS, WORD_BITS);
            else
                for (unsigned w = 0; w < 4; w++) lam[4 * k + w] = get_bits(data, base + w * WORD_BITS, WORD_BITS);
        }
        (kinds[pass] ? have_lamT : have_lam)[slot] = 1;
        written_pass[slot] = int64_t(pass);
        written_at[slot] = now;
        n_out++;
    }
};
#endif

// DDR bandwidth shared by the streams: a token bucket of bytes (rate 0 = uncapped)
struct DdrBucket {
    double rate, cap, credit = 0.0;
    DdrBucket(double r, double c) : rate(r), cap(c) {}
    void refill() {
        if (rate > 0.0) credit = credit + rate < cap ? credit + rate : cap;
    }
    bool available(size_t nbytes) const { return rate <= 0.0 || credit >= double(nbytes); }
    void spend(size_t nbytes) {
        if (rate > 0.0) credit -= double(nbytes);
    }
};

struct Sim {
    std::unique_ptr<VerilatedContext> ctx;
    std::unique_ptr<Vpgs_kernel> top;
    uint64_t cycle = 0;
    uint64_t clock_ps = 1000;  // clock period: the FST's time step per cycle
#if VM_TRACE
    std::unique_ptr<VerilatedFstC> fst;
    uint64_t wave_cycles = 0;  // 0: all
    std::FILE* phases = nullptr;  // phase changes of the sequencer, beside the FST
    unsigned phase = ~0u;
    void open_waves() {
        const char* path = std::getenv("PGS_WAVES");
        if (!path || !*path) return;
        if (ctx->timeprecision() != -12) fail("the model's time precision is not 1 ps");
        const char* n = std::getenv("PGS_WAVE_CYCLES");
        wave_cycles = n ? std::strtoull(n, nullptr, 0) : 20000;
        ctx->traceEverOn(true);
        fst = std::make_unique<VerilatedFstC>();
        top->trace(fst.get(), 99);
        fst->open(path);
        std::string base(path);
        if (base.size() > 4 && base.compare(base.size() - 4, 4, ".fst") == 0) base.resize(base.size() - 4);
        phases = std::fopen((base + ".phases").c_str(), "w");
        if (!phases) fail("cannot create " + base + ".phases");
        std::fprintf(phases, "clock_ps %llu\n", (unsigned long long)clock_ps);
    }
    void dump(uint64_t t) {
        if (!fst) return;
        if (wave_cycles && cycle >= wave_cycles) {
            fst->close();
            fst.reset();
            return;
        }
        fst->dump(t);
    }
    void mark(const char* name) {
        if (phases) std::fprintf(phases, "%s %llu\n", name, (unsigned long long)cycle);
    }
    void watch_phase() {
        static const char* const names[] = {"IDLE", "LOAD", "SOLVE", "DRAIN", "INTEG", "DONE"};
        const unsigned now = top->rootp->pgs_kernel__DOT__u_seq__DOT__phase;
        if (phases && now != phase && now < sizeof names / sizeof names[0]) mark(names[now]);
        phase = now;
    }
    void close_waves() {
        if (fst) fst->close();
        if (phases) std::fclose(phases);
    }
#else
    void open_waves() {}
    void dump(uint64_t) {}
    void mark(const char*) {}
    void watch_phase() {}
    void close_waves() {}
#endif
    Sim() : ctx(std::make_unique<VerilatedContext>()) {}
    // one clock cycle: inputs must be set before; `pre` sees the settled pre-edge outputs
    template <typename F>
    void tick(F pre) {
        top->ap_clk = 0;
        top->eval();
        dump(cycle * clock_ps);
        pre();
        top->ap_clk = 1;
        top->eval();
        dump(cycle * clock_ps + clock_ps / 2);
        cycle++;
        watch_phase();
    }
    void tick() { tick([] {}); }
};

void axil_write(Sim& s, uint32_t addr, uint32_t data) {
    auto* t = s.top.get();
    t->s_axi_control_AWADDR = addr;
    t->s_axi_control_AWVALID = 1;
    t->s_axi_control_WDATA = data;
    t->s_axi_control_WSTRB = 0xF;
    t->s_axi_control_WVALID = 1;
    t->s_axi_control_BREADY = 1;
    bool aw = false, w = false, b = false;
    for (int n = 0; n < 100 && !b; n++) {
        s.tick([&] {
            if (!aw && t->s_axi_control_AWREADY) aw = true;
            else if (aw && !w && t->s_axi_control_WREADY) w = true;
            else if (w && t->s_axi_control_BVALID) b = true;
        });
        if (aw) t->s_axi_control_AWVALID = 0;
        if (w) t->s_axi_control_WVALID = 0;
    }
    t->s_axi_control_BREADY = 0;
    if (!b) fail("AXI4-Lite write timed out");
}

uint32_t axil_read(Sim& s, uint32_t addr) {
    auto* t = s.top.get();
    t->s_axi_control_ARADDR = addr;
    t->s_axi_control_ARVALID = 1;
    t->s_axi_control_RREADY = 1;
    bool ar = false, r = false;
    uint32_t data = 0;
    for (int n = 0; n < 100 && !r; n++) {
        s.tick([&] {
            if (!ar && t->s_axi_control_ARREADY) ar = true;
            else if (ar && t->s_axi_control_RVALID) {
                r = true;
                data = t->s_axi_control_RDATA;
            }
        });
        if (ar) t->s_axi_control_ARVALID = 0;
    }
    t->s_axi_control_RREADY = 0;
    if (!r) fail("AXI4-Lite read timed out");
    return data;
}

}  // namespace

int main(int argc, char** argv) {
    if (argc < 6) {
        std::fprintf(stderr, "usage: %s DIR SEED GAP_PERMILLE BP_PERMILLE MAX_CYCLES [DDR_MILLIBYTES STARTUP "
                     "PROGRESS CLOCK_PS]\n", argv[0]);
        return 1;
    }
    const std::string dir = argv[1];
    const uint64_t seed = std::strtoull(argv[2], nullptr, 0);
    const unsigned gap = unsigned(std::strtoul(argv[3], nullptr, 0));
    const unsigned bp = unsigned(std::strtoul(argv[4], nullptr, 0));
    const uint64_t max_cycles = std::strtoull(argv[5], nullptr, 0);
    const double ddr_rate = argc > 6 ? double(std::strtoull(argv[6], nullptr, 0)) / 1000.0 : 0.0;
    const unsigned startup = argc > 7 ? unsigned(std::strtoul(argv[7], nullptr, 0)) : 0;
    const uint64_t progress = argc > 8 ? std::strtoull(argv[8], nullptr, 0) : 0;
    const uint64_t clock_ps = argc > 9 ? std::strtoull(argv[9], nullptr, 0) : 1000;
    if (clock_ps < 2) fail("CLOCK_PS must be at least 2 (ps per clock period)");

    const std::vector<uint8_t> regs = read_file(dir + "/regs.bin");
    const std::vector<uint8_t> body_in = read_file(dir + "/body_in.bin");
    const std::vector<uint8_t> body_in_last = read_file(dir + "/body_in_last.bin");
    const std::vector<uint8_t> cons = read_file(dir + "/cons.bin");
    const std::vector<uint8_t> cons_last = read_file(dir + "/cons_last.bin");
    const size_t n_body = body_in.size() / BODY_IN_BYTES, n_cons = cons.size() / CONS_BYTES;
    if (n_body != body_in_last.size() || n_cons != cons_last.size()) fail("beat / TLAST files disagree");

    Sim s;
    s.clock_ps = clock_ps;
    s.ctx->randReset(2);
    s.ctx->randSeed(int(seed & 0x7fffffff));
    s.top = std::make_unique<Vpgs_kernel>(s.ctx.get(), "pgs_kernel");
    s.open_waves();
    Rng rng(seed);
    auto* t = s.top.get();
    t->ap_rst_n = 0;
    t->s_axi_control_AWVALID = t->s_axi_control_WVALID = t->s_axi_control_ARVALID = 0;
    t->s_axi_control_BREADY = t->s_axi_control_RREADY = 0;
    t->s_axis_body_TVALID = t->s_axis_cons_TVALID = 0;
    t->m_axis_body_TREADY = 0;
    t->m_axis_imp_TREADY = 0;
#if IMPULSES_IN_RECORDS
    ImpulseBuffer imp;
    imp.load(read_file(dir + "/impulse_plan.bin"), n_cons);
    std::FILE* fimp = std::fopen((dir + "/imp_out.bin").c_str(), "wb");
    std::FILE* fimp_last = std::fopen((dir + "/imp_out_last.bin").c_str(), "wb");
    if (!fimp || !fimp_last) fail("cannot create impulse-out files");
    uint8_t ibuf[IMP_OUT_BYTES];
#endif
    for (int i = 0; i < 8; i++) s.tick();
    t->ap_rst_n = 1;
    s.tick();

    for (size_t i = 0; i + 8 <= regs.size(); i += 8) {
        uint32_t a, v;
        std::memcpy(&a, &regs[i], 4);
        std::memcpy(&v, &regs[i + 4], 4);
        axil_write(s, a, v);
    }
    axil_write(s, 0x04, 1);  // GIE
    axil_write(s, 0x08, 1);  // IER: ap_done
    s.mark("start");
    axil_write(s, 0x00, 1);  // ap_start
    const uint64_t start_cycle = s.cycle;

    std::FILE* ftrace = std::fopen((dir + "/trace.bin").c_str(), "wb");
    std::FILE* fout = std::fopen((dir + "/body_out.bin").c_str(), "wb");
    std::FILE* fout_last = std::fopen((dir + "/body_out_last.bin").c_str(), "wb");
    if (!ftrace || !fout || !fout_last) fail("cannot create output files");

    size_t bi = 0, ci = 0, n_out = 0, n_trace = 0;
    DdrBucket ddr(ddr_rate, 2.0 * CONS_BYTES);
    unsigned body_wait = startup, cons_wait = startup;  // start-up latency of the transfer in progress
    uint8_t buf[BODY_OUT_BYTES > LANES * TRACE_BYTES ? BODY_OUT_BYTES : LANES * TRACE_BYTES];
    const auto t0 = std::chrono::steady_clock::now();
    bool finished = false;
    while (!finished) {
        if (s.cycle - start_cycle > max_cycles) {
            char msg[512];
            std::snprintf(msg, sizeof msg,
                          "TIMEOUT after %llu cycles: body-in beats %zu/%zu, constraint beats %zu/%zu, body-out beats "
                          "%zu, trace records %zu, ap_idle pending (interrupt never rose)",
                          (unsigned long long)max_cycles, bi, n_body, ci, n_cons, n_out, n_trace);
            fail(msg, 3);
        }
        if (progress && (s.cycle - start_cycle) % progress == 0) {
            std::printf("progress %llu %zu\n", (unsigned long long)(s.cycle - start_cycle), n_trace);
            std::fflush(stdout);
        }
        // offer beats (a new beat may wait a start-up latency, DDR credit and a random gap; a valid beat stays
        // until taken)
        ddr.refill();
        if (body_wait) body_wait--;
        if (cons_wait) cons_wait--;
        if (!t->s_axis_body_TVALID && bi < n_body && !body_wait && ddr.available(BODY_IN_BYTES) && !rng.chance(gap)) {
            set_wide(t->s_axis_body_TDATA, &body_in[bi * BODY_IN_BYTES], BODY_IN_BYTES);
            t->s_axis_body_TLAST = body_in_last[bi];
            t->s_axis_body_TVALID = 1;
            ddr.spend(BODY_IN_BYTES);
        }
#if IMPULSES_IN_RECORDS
        const size_t first = ci < n_cons && !t->s_axis_cons_TVALID ? imp.first_of(ci) : ~size_t(0);
        const bool raw_ok = first == ~size_t(0) || imp.readable(first, s.cycle - start_cycle);
#else
        const bool raw_ok = true;
#endif
        if (!t->s_axis_cons_TVALID && ci < n_cons && !cons_wait && raw_ok && ddr.available(CONS_BYTES) &&
            !rng.chance(gap)) {
#if IMPULSES_IN_RECORDS
            if (first != ~size_t(0)) imp.compose(first, cons);
            set_wide(t->s_axis_cons_TDATA, imp.beat(ci), CONS_BYTES);
#else
            set_wide(t->s_axis_cons_TDATA, &cons[ci * CONS_BYTES], CONS_BYTES);
#endif
            t->s_axis_cons_TLAST = cons_last[ci];
            t->s_axis_cons_TVALID = 1;
            ddr.spend(CONS_BYTES);
        }
        t->m_axis_body_TREADY = ddr.available(BODY_OUT_BYTES) && !rng.chance(bp);
#if IMPULSES_IN_RECORDS
        t->m_axis_imp_TREADY = !rng.chance(bp);
#endif
        bool body_hs = false, cons_hs = false;
        s.tick([&] {
            body_hs = t->s_axis_body_TVALID && t->s_axis_body_TREADY;
            cons_hs = t->s_axis_cons_TVALID && t->s_axis_cons_TREADY;
            if (t->m_axis_body_TVALID && t->m_axis_body_TREADY) {
                get_wide(t->m_axis_body_TDATA, buf, BODY_OUT_BYTES);
                std::fwrite(buf, 1, BODY_OUT_BYTES, fout);
                uint8_t l = t->m_axis_body_TLAST;
                std::fwrite(&l, 1, 1, fout_last);
                n_out++;
                ddr.spend(BODY_OUT_BYTES);
            }
#if IMPULSES_IN_RECORDS
            if (t->m_axis_imp_TVALID && t->m_axis_imp_TREADY) {
                get_wide(t->m_axis_imp_TDATA, ibuf, IMP_OUT_BYTES);
                std::fwrite(ibuf, 1, IMP_OUT_BYTES, fimp);
                uint8_t l = t->m_axis_imp_TLAST;
                std::fwrite(&l, 1, 1, fimp_last);
                imp.write(ibuf, s.cycle - start_cycle);
            }
#endif
            if (t->trace_valid) {
                uint64_t c = s.cycle - start_cycle;
                get_wide(t->trace_data, buf, LANES * TRACE_BYTES);
                for (unsigned l = 0; l < LANES; l++) {
                    if (!((t->trace_valid >> l) & 1u)) continue;
                    std::fwrite(&c, 8, 1, ftrace);
                    std::fwrite(buf + l * TRACE_BYTES, 1, TRACE_BYTES, ftrace);
                    n_trace++;
                }
            }
            finished = t->__SYM__interrupt;  // Verilator renames the port `interrupt`
        });
        if (body_hs) {
            t->s_axis_body_TVALID = 0;
            bi++;
        }
        if (cons_hs) {
            if (t->s_axis_cons_TLAST) cons_wait = startup;  // the host starts the next pass's transfer
            t->s_axis_cons_TVALID = 0;
            ci++;
        }
    }
    const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    const uint64_t run_cycles = s.cycle - start_cycle;
    std::fclose(ftrace);
    std::fclose(fout);
    std::fclose(fout_last);
#if IMPULSES_IN_RECORDS
    std::fclose(fimp);
    std::fclose(fimp_last);
#endif

    const uint32_t ap_ctrl = axil_read(s, 0x00);
    const uint32_t isr = axil_read(s, 0x0C);
    std::FILE* fr = std::fopen((dir + "/result.txt").c_str(), "w");
    if (!fr) fail("cannot create result.txt");
    std::fprintf(fr, "ap_ctrl %u\nisr %u\nstatus %u\n", ap_ctrl, isr, axil_read(s, 0x58));
    const uint64_t cyc = uint64_t(axil_read(s, 0x60)) | (uint64_t(axil_read(s, 0x64)) << 32);
    std::fprintf(fr, "cycles %llu\n", (unsigned long long)cyc);
    std::fprintf(fr, "stalls %u\nbubbles %u\nissued %u\n", axil_read(s, 0x68), axil_read(s, 0x70), axil_read(s, 0x78));
    std::fprintf(fr, "rejected %u\nfp_overflow %u\nfp_underflow %u\nfp_invalid %u\nfp_status %u\n", axil_read(s, 0x7C),
                 axil_read(s, 0x80), axil_read(s, 0x84), axil_read(s, 0x88), axil_read(s, 0x8C));
    std::fprintf(fr, "harness_cycles %llu\nwall_s %.6f\nbody_in_beats_taken %zu\ncons_beats_taken %zu\n",
                 (unsigned long long)run_cycles, wall, bi, ci);
    std::fprintf(fr, "body_out_beats %zu\ntrace_records %zu\n", n_out, n_trace);
#if IMPULSES_IN_RECORDS
    std::fprintf(fr, "impulse_out_records %zu\n", imp.n_out);
#endif
    std::fclose(fr);
    t->final();
    s.close_waves();
    return 0;
}
