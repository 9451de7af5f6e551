// pgs_csim_dma.h: the DMA of the records designs (PGS_IMPULSES_IN_RECORDS = 1) for the C simulation testbench,
// the model of models/timing/platforms.py and of the RTL harness (sim/harness/pgs_kernel_main.cpp, ImpulseBuffer) without
// its timing.
//
// The host writes the impulses the step starts from (zeros or a warm start) into the DDR impulse buffer (lam[4],
// lamT[2] per slot): cons.bin holds every block's records with them. A block is a pass of the streaming kernel or a
// fetch of the window kernel (PGS_WINDOW > 0, each serving passes of one kind). The DMA reads each record as its
// static words with the buffer's words and writes each impulse-out record (m_axis_imp) into its slots' fields of the
// block's kind (contact lam, friction lamT). Read after write: record k of block p > 0 is streamed only after block
// p - 1's impulse-out record k was taken (every block reads what its predecessor wrote, or older). The kernel runs
// in another thread; the DMA feeds s_axis_cons record by record, waiting on m_axis_imp where the rule says so. A
// kernel that ends before the record the DMA waits for (a refused argument) ends the streaming there.
// The layout: generated/pgs_stream_layout.h through pgs_stream.h (kContactLamWord, kFrictionLamAt, ...); the block
// plan: DIR/impulse_plan.bin (uint32 records per block, uint32 turnaround (ignored: untimed), uint32 beats per
// record: 0 by the block's kind (the streaming kernel), > 0 every record that many beats (the window kernel:
// kLanes lane records of beats / kLanes beats, lane l's impulse words l beats / kLanes beats into the record; an
// impulse-out record holds kLanes x 4 words), one byte per block, 0 contact, 1 friction), as sim/drive/harness_run.py
// writes it for the RTL harness.
#ifndef PGS_CSIM_DMA_H
#define PGS_CSIM_DMA_H

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "pgs_stream.h"

namespace pgs {

// `nbits` (<= 32) little-endian bits at bit `pos` of a byte array
inline uint32_t get_bits(const uint8_t* p, size_t pos, unsigned nbits) {
    uint32_t v = 0;
    for (unsigned i = 0; i < nbits; i++) v |= uint32_t((p[(pos + i) / 8] >> ((pos + i) % 8)) & 1u) << i;
    return v;
}
inline void set_bits(uint8_t* p, size_t pos, unsigned nbits, uint32_t v) {
    for (unsigned i = 0; i < nbits; i++) {
        const size_t b = pos + i;
        p[b / 8] = uint8_t((p[b / 8] & ~(1u << (b % 8))) | (((v >> i) & 1u) << (b % 8)));
    }
}

class RecordsDma {
  public:
    static constexpr size_t kImpBytes = kImpOutW / 8;

    // `plan`: impulse_plan.bin; `cons`, `cons_last`: the host's constraint beats and their TLAST bytes.
    // An error is a message in error() (the DMA then streams nothing).
    // `wait_s`: how long the DMA waits for an impulse-out record before it gives the kernel up as stuck.
    RecordsDma(const std::vector<uint8_t>& plan, const std::vector<uint8_t>& cons, const std::vector<uint8_t>& last,
               double wait_s)
        : cons_(cons), last_(last), wait_s_(wait_s) {
        if (plan.size() < 12) {
            error_ = "impulse_plan.bin: too short";
            return;
        }
        uint32_t r32, b32;
        std::memcpy(&r32, &plan[0], 4);
        std::memcpy(&b32, &plan[8], 4);
        if ((b32 != 0) != (kWindow > 0) || (b32 != 0 && b32 != uint32_t(kWindowRecBeats))) {
            error_ = "impulse_plan.bin: " + std::to_string(b32) + " beats per record (0: the streaming kernel's by " +
                     "kind), the build's window records have " + std::to_string(kWindow ? kWindowRecBeats : 0);
            return;
        }
        records_ = r32;
        record_beats_ = b32;
        kinds_.assign(plan.begin() + 12, plan.end());
        size_t beats = 0;
        for (uint8_t k : kinds_) beats += records_ * beats_of(k);
        if (beats != last.size()) error_ = "constraint stream does not match impulse_plan.bin";
        lam_.assign(4 * kLanes * records_, 0);
        lam_t_.assign(2 * kLanes * records_, 0);
        have_lam_.assign(records_, 0);
        have_lam_t_.assign(records_, 0);
    }

    const std::string& error() const { return error_; }
    size_t records_out() const { return records_out_; }
    size_t beats_fed() const { return beats_fed_; }                         // the constraint beats streamed
    const std::vector<uint8_t>& imp_out() const { return imp_out_; }        // the impulse-out records taken
    const std::vector<uint8_t>& imp_out_last() const { return imp_last_; }  // and their TLAST

    // Stream every record to the kernel running in another thread, taking its impulse-out records as the
    // read-after-write rule needs them. Returns false (error()) if the kernel stops writing them while it runs.
    bool stream_records(hls::stream<cons_beat_t>& s_axis_cons, hls::stream<imp_beat_t>& m_axis_imp) {
        bool more = true;
        for (size_t block = 0; block < kinds_.size() && more; block++) {
            const size_t nbeats = beats_of(kinds_[block]);
            for (size_t rec = 0; rec < records_ && more; rec++) {
                more = block == 0 || take_until((block - 1) * records_ + rec + 1, m_axis_imp);
                if (more) {
                    feed(s_axis_cons, compose(block, rec, beats_fed_), beats_fed_, nbeats);
                    beats_fed_ += nbeats;
                }
            }
        }
        s_axis_cons.close_producer();  // the kernel's further reads (a bad input) find the stream empty
        return error_.empty();
    }

    // After the kernel finished: the impulse-out records not taken yet.
    void drain(hls::stream<imp_beat_t>& m_axis_imp) {
        imp_beat_t b;
        while (m_axis_imp.read_nb(b)) write_back(b);
    }

  private:
    size_t beats_of(uint8_t kind) const {
        return record_beats_ ? record_beats_ : kind ? kFrictionBeats : kContactBeats;
    }

    // take impulse-out records until `count` were taken; false when the kernel finished first (closing the stream:
    // the step ended early) or wrote none for wait_s_ seconds (error())
    bool take_until(size_t count, hls::stream<imp_beat_t>& m_axis_imp) {
        while (records_out_ < count) {
            imp_beat_t b;
            if (!m_axis_imp.read_wait(b, wait_s_)) {
                if (m_axis_imp.producer_open())
                    error_ = "no impulse-out record " + std::to_string(records_out_) + " for " +
                             std::to_string(int(wait_s_)) + " s; the DMA waits for record " + std::to_string(count - 1);
                return false;
            }
            write_back(b);
        }
        return true;
    }

    // an impulse-out record: logged, and its lanes' words written into their slots' fields of its block's kind
    void write_back(const imp_beat_t& b) {
        uint8_t bytes[kImpBytes];
        for (size_t i = 0; i < kImpBytes; i++) bytes[i] = uint8_t(b.data.range(8 * i + 7, 8 * i).to_uint());
        imp_out_.insert(imp_out_.end(), bytes, bytes + kImpBytes);
        imp_last_.push_back(b.last.to_uint() ? 1 : 0);
        const size_t block = records_ ? records_out_ / records_ : kinds_.size();
        const size_t rec = records_ ? records_out_ % records_ : 0;
        records_out_++;
        if (block >= kinds_.size()) {
            error_ = "more impulse-out records than the blocks have records";
            return;
        }
        for (size_t l = 0; l < size_t(kLanes); l++) {
            const size_t k = rec * kLanes + l, base = 4 * l * kWordBits;
            if (kinds_[block])
                for (unsigned w = 0; w < 2; w++) lam_t_[2 * k + w] = get_bits(bytes, base + w * kWordBits, kWordBits);
            else
                for (unsigned w = 0; w < 4; w++) lam_[4 * k + w] = get_bits(bytes, base + w * kWordBits, kWordBits);
        }
        (kinds_[block] ? have_lam_t_ : have_lam_)[rec] = 1;
    }

    // the bytes of the record at `beat`: the host's, with the buffer's words where a block of the step wrote them
    // (lane l's record at l beats / kLanes beats)
    std::vector<uint8_t> compose(size_t block, size_t rec, size_t beat) const {
        const size_t nbeats = beats_of(kinds_[block]), bytes = nbeats * kConsW / 8;
        std::vector<uint8_t> out(cons_.begin() + beat * (kConsW / 8), cons_.begin() + beat * (kConsW / 8) + bytes);
        const size_t lam_bit = kHeaderBits + size_t(kinds_[block] ? kFrictionLamAt : kContactLamWord) * kWordBits;
        const size_t lamt_bit = kHeaderBits + size_t(kFrictionLamtAt) * kWordBits;
        for (size_t l = 0; l < size_t(kLanes); l++) {
            const size_t base = l * nbeats / kLanes * kConsW, k = rec * kLanes + l;
            if (have_lam_[rec])
                for (unsigned w = 0; w < 4; w++)
                    set_bits(out.data(), base + lam_bit + w * kWordBits, kWordBits, lam_[4 * k + w]);
            if (kinds_[block] && have_lam_t_[rec])
                for (unsigned w = 0; w < 2; w++)
                    set_bits(out.data(), base + lamt_bit + w * kWordBits, kWordBits, lam_t_[2 * k + w]);
        }
        return out;
    }

    void feed(hls::stream<cons_beat_t>& s, const std::vector<uint8_t>& rec, size_t beat, size_t nbeats) const {
        for (size_t j = 0; j < nbeats; j++) {
            cons_beat_t b;
            for (int i = 0; i < kConsW / 8; i++) b.data.range(8 * i + 7, 8 * i) = rec[j * (kConsW / 8) + i];
            b.keep = all_ones<kConsW / 8>();
            b.strb = all_ones<kConsW / 8>();
            b.last = last_[beat + j] ? 1 : 0;
            s.write(b);
        }
    }

    const std::vector<uint8_t>& cons_;
    const std::vector<uint8_t>& last_;
    double wait_s_;
    size_t records_ = 0;      // records per block (a window record holds kLanes slots)
    size_t record_beats_ = 0;  // 0: by the block's kind
    std::vector<uint8_t> kinds_;
    std::vector<uint32_t> lam_, lam_t_;          // 4 and 2 words per slot (record * kLanes + lane)
    std::vector<uint8_t> have_lam_, have_lam_t_;  // per record: written by a block of this step
    size_t records_out_ = 0, beats_fed_ = 0;
    std::vector<uint8_t> imp_out_, imp_last_;
    std::string error_;
};

}  // namespace pgs

#endif  // PGS_CSIM_DMA_H
