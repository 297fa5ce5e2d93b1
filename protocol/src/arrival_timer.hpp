// Times the reads of one received message (MessageStream::Arrival, issue 36 §1): a link narrower
// than the sender spaces the bytes of a message written at once by bytes / rate, so the bytes
// read after a message's first read, over the time to its last, are the rate the link delivered
// them at. What had arrived by the first read is not counted (it arrived at some earlier time),
// nor what the reads right after it return without waiting (kBurstGap: bytes already there).
//
// Over TLS a read completes a record at a time (up to 16 kB: a frame may be one record, there
// whole at its only read), so a TLS transport times the reads beneath it instead: each read
// OpenSSL makes of the bytes asio took off the socket as they came (time_tls_reads, a BIO
// callback), and not its own.
#pragma once

#include <openssl/ssl.h>

#include <chrono>
#include <cstddef>

#include "arlight/protocol/arrival.hpp"

namespace arlight::wire {

class ArrivalTimer {
 public:
  static constexpr std::chrono::microseconds kBurstGap{1000};

  // A message's read begins / ended: reads count in between.
  void start() { reading_ = true, reads_ = 0, bytes_after_first_ = 0; }
  void stop() { reading_ = false; }
  void read(std::size_t bytes) {
    if (!reading_ || bytes == 0) return;
    const auto now = Clock::now();
    if (reads_++ == 0 || (bytes_after_first_ == 0 && now - last_ < kBurstGap))
      first_ = now;  // the first read, or one that found its bytes there with it
    else
      bytes_after_first_ += bytes;
    last_ = now;
  }
  Arrival arrival() const {
    if (bytes_after_first_ == 0) return {};
    return {bytes_after_first_, std::chrono::duration<double>(last_ - first_).count()};
  }

 private:
  using Clock = std::chrono::steady_clock;
  bool reading_ = false;
  int reads_ = 0;
  std::size_t bytes_after_first_ = 0;
  Clock::time_point first_, last_;
};

// Feeds `timer` every read OpenSSL makes of `ssl`'s network bytes (nullptr: no more; call it
// before the timer goes while the SSL object may still read).
void time_tls_reads(SSL* ssl, ArrivalTimer* timer);

}  // namespace arlight::wire
