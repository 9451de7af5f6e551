// pgs_csim_dma.h: the DMA of the records design (PGS_IMPULSES_IN_RECORDS = 1) for the C simulation testbench,
// the model of models/dma_model.py and of the RTL harness (sim/harness/pgs_kernel_main.cpp, ImpulseBuffer) without
// its timing.
//
// The host writes the impulses the step starts from (zeros or a warm start) into the DDR impulse buffer (lam[4],
// lamT[2] per slot): cons.bin holds every pass's records with them. The DMA reads each record as its static words
// with the buffer's words and writes each impulse-out record (m_axis_imp) into its slot's field of the pass's kind
// (contact lam, friction lamT). Read after write: record k of pass p > 0 is streamed only after pass p - 1's
// impulse-out record of slot k was taken (every pass reads what its predecessor wrote, or older). The kernel runs
// in another thread; the DMA feeds s_axis_cons record by record, waiting on m_axis_imp where the rule says so.
// The layout: generated/pgs_stream_layout.h through pgs_stream.h (kContactLamWord, kFrictionLamAt, ...); the pass
// plan: DIR/impulse_plan.bin (uint32 slots per pass, uint32 turnaround (ignored: untimed), uint32 beats per record
// (0 here: by the pass's kind; the window kernel's records are refused), one byte per pass, 0 contact, 1
// friction), as sim/harness_run.py writes it for the RTL harness.
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
        uint32_t s32, b32;
        std::memcpy(&s32, &plan[0], 4);
        std::memcpy(&b32, &plan[8], 4);
        if (b32 != 0) {  // the window kernel's records: the HLS kernel is the streaming one
            error_ = "impulse_plan.bin: records of the window kernel (the HLS kernel streams every pass's records)";
            return;
        }
        slots_ = s32;
        kinds_.assign(plan.begin() + 12, plan.end());
        size_t beats = 0;
        for (uint8_t k : kinds_) beats += slots_ * beats_of(k);
        if (beats != last.size()) error_ = "constraint stream does not match impulse_plan.bin";
        lam_.assign(4 * slots_, 0);
        lam_t_.assign(2 * slots_, 0);
        have_lam_.assign(slots_, 0);
        have_lam_t_.assign(slots_, 0);
    }

    const std::string& error() const { return error_; }
    size_t records_out() const { return records_out_; }
    const std::vector<uint8_t>& imp_out() const { return imp_out_; }        // the impulse-out records taken
    const std::vector<uint8_t>& imp_out_last() const { return imp_last_; }  // and their TLAST

    // Stream every record to the kernel running in another thread, taking its impulse-out records as the
    // read-after-write rule needs them. Returns false (error()) if the kernel stops writing them early.
    bool stream_records(hls::stream<cons_beat_t>& s_axis_cons, hls::stream<imp_beat_t>& m_axis_imp) {
        size_t beat = 0;
        for (size_t pass = 0; pass < kinds_.size() && error_.empty(); pass++) {
            const size_t nbeats = beats_of(kinds_[pass]);
            for (size_t slot = 0; slot < slots_; slot++) {
                if (pass > 0 && !take_until((pass - 1) * slots_ + slot + 1, m_axis_imp)) break;
                feed(s_axis_cons, compose(pass, slot, beat), beat, nbeats);
                beat += nbeats;
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
    static size_t beats_of(uint8_t kind) { return kind ? kFrictionBeats : kContactBeats; }

    // take impulse-out records until `count` were taken (or the kernel finished, closing the stream: false)
    bool take_until(size_t count, hls::stream<imp_beat_t>& m_axis_imp) {
        while (records_out_ < count) {
            imp_beat_t b;
            if (!m_axis_imp.read_wait(b, wait_s_)) {
                error_ = "no impulse-out record " + std::to_string(records_out_) + " (the kernel finished, or " +
                         "wrote nothing for " + std::to_string(int(wait_s_)) + " s); the DMA waits for record " +
                         std::to_string(count - 1);
                return false;
            }
            write_back(b);
        }
        return true;
    }

    // an impulse-out record: logged, and written into its slot's field of its pass's kind
    void write_back(const imp_beat_t& b) {
        uint8_t bytes[kImpBytes];
        for (size_t i = 0; i < kImpBytes; i++) bytes[i] = uint8_t(b.data.range(8 * i + 7, 8 * i).to_uint());
        imp_out_.insert(imp_out_.end(), bytes, bytes + kImpBytes);
        imp_last_.push_back(b.last.to_uint() ? 1 : 0);
        const size_t pass = slots_ ? records_out_ / slots_ : kinds_.size(), slot = slots_ ? records_out_ % slots_ : 0;
        records_out_++;
        if (pass >= kinds_.size()) {
            error_ = "more impulse-out records than the passes have slots";
            return;
        }
        if (kinds_[pass]) {
            for (unsigned w = 0; w < 2; w++) lam_t_[2 * slot + w] = get_bits(bytes, w * kWordBits, kWordBits);
            have_lam_t_[slot] = 1;
        } else {
            for (unsigned w = 0; w < 4; w++) lam_[4 * slot + w] = get_bits(bytes, w * kWordBits, kWordBits);
            have_lam_[slot] = 1;
        }
    }

    // the bytes of the record at `beat`: the host's, with the buffer's words where a pass of the step wrote them
    std::vector<uint8_t> compose(size_t pass, size_t slot, size_t beat) const {
        const size_t bytes = beats_of(kinds_[pass]) * kConsW / 8;
        std::vector<uint8_t> rec(cons_.begin() + beat * (kConsW / 8), cons_.begin() + beat * (kConsW / 8) + bytes);
        const size_t lam_bit = kHeaderBits + size_t(kinds_[pass] ? kFrictionLamAt : kContactLamWord) * kWordBits;
        if (have_lam_[slot])
            for (unsigned w = 0; w < 4; w++)
                set_bits(rec.data(), lam_bit + w * kWordBits, kWordBits, lam_[4 * slot + w]);
        if (kinds_[pass] && have_lam_t_[slot])
            for (unsigned w = 0; w < 2; w++)
                set_bits(rec.data(), kHeaderBits + size_t(kFrictionLamtAt + w) * kWordBits, kWordBits,
                         lam_t_[2 * slot + w]);
        return rec;
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
    size_t slots_ = 0;
    std::vector<uint8_t> kinds_;
    std::vector<uint32_t> lam_, lam_t_;
    std::vector<uint8_t> have_lam_, have_lam_t_;
    size_t records_out_ = 0;
    std::vector<uint8_t> imp_out_, imp_last_;
    std::string error_;
};

}  // namespace pgs

#endif  // PGS_CSIM_DMA_H
