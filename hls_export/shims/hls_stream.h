// hls_stream.h (shim): hls::stream<T> for C simulation with g++ where the Vitis headers are absent
// (hls_export/pgs_hls.h includes it only then). An unbounded FIFO with the calls hls_export/ uses:
// read(), read(T&), write(), empty(), size(), read_nb(), >> and <<. Reading an empty stream behaves like
// Vitis HLS's C simulation (a warning on stderr, a default-constructed value), and is counted in
// empty_reads() so that a testbench can fail on it (in hardware the kernel would wait forever).
#ifndef PGS_SHIM_HLS_STREAM_H
#define PGS_SHIM_HLS_STREAM_H

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdio>
#include <deque>
#include <mutex>
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
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait(lock, [this] { return !q_.empty() || !producer_open_; });
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
    // the testbench's blocking read: waits for a value (true), for close_producer() on an empty stream or for
    // `timeout_s` seconds (false)
    bool read_wait(T& v, double timeout_s) {
        std::unique_lock<std::mutex> lock(m_);
        cv_.wait_for(lock, std::chrono::duration<double>(timeout_s), [this] { return !q_.empty() || !producer_open_; });
        if (q_.empty()) return false;
        v = q_.front();
        q_.pop_front();
        return true;
    }
    bool read_nb(T& v) {
        std::lock_guard<std::mutex> lock(m_);
        if (q_.empty()) return false;
        v = q_.front();
        q_.pop_front();
        return true;
    }
    void write(const T& v) {
        {
            std::lock_guard<std::mutex> lock(m_);
            q_.push_back(v);
        }
        cv_.notify_all();
    }
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
    bool empty() const {
        std::lock_guard<std::mutex> lock(m_);
        return q_.empty();
    }
    bool full() const { return false; }
    std::size_t size() const {
        std::lock_guard<std::mutex> lock(m_);
        return q_.size();
    }
    std::size_t empty_reads() const {
        std::lock_guard<std::mutex> lock(m_);
        return empty_reads_;
    }
    // a producer in another thread will write: reads of an empty stream wait for it until close_producer()
    void open_producer() {
        std::lock_guard<std::mutex> lock(m_);
        producer_open_ = true;
    }
    // whether a producer opened the stream and has not closed it yet
    bool producer_open() const {
        std::lock_guard<std::mutex> lock(m_);
        return producer_open_;
    }
    void close_producer() {
        {
            std::lock_guard<std::mutex> lock(m_);
            producer_open_ = false;
        }
        cv_.notify_all();
    }

  private:
    std::deque<T> q_;
    std::string name_;
    std::size_t empty_reads_ = 0;
    bool producer_open_ = false;
    mutable std::mutex m_;
    std::condition_variable cv_;
};

}  // namespace hls

#endif  // PGS_SHIM_HLS_STREAM_H
