// hls_stream.h (shim): hls::stream<T> for C simulation with g++ where the Vitis headers are absent
// (hls_export/pgs_hls.h includes it only then). An unbounded FIFO with the calls hls_export/ uses:
// read(), read(T&), write(), empty(), size(), read_nb(), >> and <<. Reading an empty stream behaves like
// Vitis HLS's C simulation (a warning on stderr, a default-constructed value), and is counted in
// empty_reads() so that a testbench can fail on it (in hardware the kernel would wait forever).
#ifndef PGS_SHIM_HLS_STREAM_H
#define PGS_SHIM_HLS_STREAM_H

#include <cstddef>
#include <cstdio>
#include <deque>
#include <string>

namespace hls {

template <typename T>
class stream {
  public:
    stream() : name_("stream") {}
    explicit stream(const char* name) : name_(name) {}
    stream(const stream&) = delete;
    stream& operator=(const stream&) = delete;

    T read() {
        if (q_.empty()) {
            if (empty_reads_++ == 0)
                std::fprintf(stderr, "WARNING: hls::stream '%s' is read while empty\n", name_.c_str());
            return T();
        }
        T v = q_.front();
        q_.pop_front();
        return v;
    }
    void read(T& v) { v = read(); }
    bool read_nb(T& v) {
        if (q_.empty()) return false;
        v = read();
        return true;
    }
    void write(const T& v) { q_.push_back(v); }
    bool write_nb(const T& v) {
        write(v);
        return true;
    }
    stream& operator>>(T& v) {
        read(v);
        return *this;
    }
    stream& operator<<(const T& v) {
        write(v);
        return *this;
    }
    bool empty() const { return q_.empty(); }
    bool full() const { return false; }
    std::size_t size() const { return q_.size(); }
    std::size_t empty_reads() const { return empty_reads_; }

  private:
    std::deque<T> q_;
    std::string name_;
    std::size_t empty_reads_ = 0;
};

}  // namespace hls

#endif  // PGS_SHIM_HLS_STREAM_H
