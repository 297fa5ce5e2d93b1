#include "arrival_timer.hpp"

#include <openssl/bio.h>

namespace arlight::wire {

namespace {

// A BIO callback: after each read of the SSL object's network BIO, its bytes to the timer.
long on_tls_bio(BIO* bio, int operation, const char* /*argp*/, std::size_t /*len*/, int /*argi*/,
                long /*argl*/, int ret, std::size_t* processed) {
  if (operation == (BIO_CB_READ | BIO_CB_RETURN) && ret > 0 && processed)
    if (auto* timer = reinterpret_cast<ArrivalTimer*>(BIO_get_callback_arg(bio)))
      timer->read(*processed);
  return ret;
}

}  // namespace

void time_tls_reads(SSL* ssl, ArrivalTimer* timer) {
  BIO* bio = SSL_get_rbio(ssl);
  if (!bio) return;
  BIO_set_callback_arg(bio, reinterpret_cast<char*>(timer));
  BIO_set_callback_ex(bio, timer ? on_tls_bio : nullptr);
}

}  // namespace arlight::wire
