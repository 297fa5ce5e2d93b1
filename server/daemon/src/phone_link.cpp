#include "phone_link.hpp"

#include <ifaddrs.h>
#include <net/if.h>
#include <netinet/in.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <qrencode.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <boost/asio/ip/address.hpp>
#include <cstdio>
#include <fstream>
#include <memory>
#include <sstream>

#include "arlight/common/error.hpp"

namespace arlight::daemon {

namespace fs = std::filesystem;

namespace {

constexpr long kValidDays = 825;       // the longest a browser accepts for a private certificate
constexpr long kRenewBeforeDays = 30;  // made anew this close to expiry

template <class T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using Key = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;
using Cert = std::unique_ptr<X509, Deleter<X509, X509_free>>;

std::string joined(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += n + "\n";
  return s;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// The certificate at `cert` is usable for `names` for at least kRenewBeforeDays more, and its
// key is beside it.
bool still_good(const CertificateFiles& files, const fs::path& names_file,
                const std::vector<std::string>& names) {
  if (!fs::exists(files.cert) || !fs::exists(files.key) || read_text(names_file) != joined(names))
    return false;
  FILE* f = std::fopen(files.cert.c_str(), "r");
  if (!f) return false;
  const Cert x(PEM_read_X509(f, nullptr, nullptr, nullptr));
  std::fclose(f);
  if (!x) return false;
  time_t renew_at = time(nullptr) + kRenewBeforeDays * 86400;
  return X509_cmp_time(X509_get0_notAfter(x.get()), &renew_at) > 0;
}

void write_pem(const fs::path& path, bool private_key, const std::function<int(FILE*)>& write) {
  const fs::path tmp = path.string() + ".tmp";
  FILE* f = std::fopen(tmp.c_str(), "w");
  if (!f) throw std::runtime_error("cannot write " + tmp.string());
  if (private_key) ::fchmod(fileno(f), 0600);
  const bool ok = write(f) == 1;
  if (std::fclose(f) != 0 || !ok) throw std::runtime_error("cannot write " + tmp.string());
  fs::rename(tmp, path);
}

}  // namespace

CertificateFiles ensure_self_signed_certificate(const fs::path& dir,
                                                const std::vector<std::string>& names) {
  if (names.empty()) throw InputError("a certificate needs at least one name");
  CertificateFiles files{dir / "self-signed-cert.pem", dir / "self-signed-key.pem", false};
  const fs::path names_file = dir / "self-signed-names.txt";
  if (still_good(files, names_file, names)) return files;

  fs::create_directories(dir);
  const Key key(EVP_EC_gen("P-256"));
  const Cert x(X509_new());
  if (!key || !x) throw std::runtime_error("OpenSSL cannot make a key");
  X509_set_version(x.get(), 2);
  unsigned char serial[16];
  BIGNUM* bn = BN_new();
  BN_rand(bn, 8 * sizeof serial - 1, BN_RAND_TOP_ANY, BN_RAND_BOTTOM_ANY);
  BN_to_ASN1_INTEGER(bn, X509_get_serialNumber(x.get()));
  BN_free(bn);
  X509_gmtime_adj(X509_getm_notBefore(x.get()), -3600);  // clocks of phones differ a little
  X509_gmtime_adj(X509_getm_notAfter(x.get()), kValidDays * 86400);
  X509_set_pubkey(x.get(), key.get());
  X509_NAME* subject = X509_get_subject_name(x.get());
  X509_NAME_add_entry_by_txt(subject, "O", MBSTRING_UTF8,
                             reinterpret_cast<const unsigned char*>("arlightd (self-signed)"), -1,
                             -1, 0);
  X509_NAME_add_entry_by_txt(subject, "CN", MBSTRING_UTF8,
                             reinterpret_cast<const unsigned char*>(names.front().c_str()), -1, -1,
                             0);
  X509_set_issuer_name(x.get(), subject);
  std::string san;
  for (const auto& n : names) {
    boost::system::error_code ec;
    boost::asio::ip::make_address(n, ec);
    if (!san.empty()) san += ',';
    san += ec ? "DNS:" : "IP:";
    san += n;
  }
  X509V3_CTX ctx;
  X509V3_set_ctx_nodb(&ctx);
  X509V3_set_ctx(&ctx, x.get(), x.get(), nullptr, nullptr, 0);
  for (const auto& [nid, value] :
       std::vector<std::pair<int, std::string>>{{NID_subject_alt_name, san},
                                                {NID_basic_constraints, "critical,CA:FALSE"},
                                                {NID_key_usage, "critical,digitalSignature"},
                                                {NID_ext_key_usage, "serverAuth"}}) {
    X509_EXTENSION* ext = X509V3_EXT_conf_nid(nullptr, &ctx, nid, value.c_str());
    if (!ext) throw InputError("certificate names '" + san + "': not usable");
    X509_add_ext(x.get(), ext, -1);
    X509_EXTENSION_free(ext);
  }
  if (X509_sign(x.get(), key.get(), EVP_sha256()) == 0)
    throw std::runtime_error("OpenSSL cannot sign the certificate");
  // The key first: a certificate without its key would look valid on the next start.
  write_pem(files.key, true, [&](FILE* f) {
    return PEM_write_PrivateKey(f, key.get(), nullptr, nullptr, 0, nullptr, nullptr);
  });
  write_pem(files.cert, false, [&](FILE* f) { return PEM_write_X509(f, x.get()); });
  std::ofstream(names_file) << joined(names);
  files.created = true;
  return files;
}

std::vector<std::string> local_names() {
  std::vector<std::string> names = {"localhost", "127.0.0.1"};
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) == 0 && host[0] &&
      std::find(names.begin(), names.end(), host) == names.end())
    names.emplace_back(host);
  ifaddrs* list = nullptr;
  if (getifaddrs(&list) == 0) {
    for (const ifaddrs* a = list; a; a = a->ifa_next) {
      if (!a->ifa_addr || a->ifa_addr->sa_family != AF_INET || !(a->ifa_flags & IFF_UP) ||
          (a->ifa_flags & IFF_LOOPBACK))
        continue;
      const auto* in = reinterpret_cast<const sockaddr_in*>(a->ifa_addr);
      const std::string ip = boost::asio::ip::address_v4(ntohl(in->sin_addr.s_addr)).to_string();
      if (std::find(names.begin(), names.end(), ip) == names.end()) names.push_back(ip);
    }
    freeifaddrs(list);
  }
  return names;
}

std::string reachable_host(const std::string& bind_host) {
  if (bind_host != "0.0.0.0" && bind_host != "::" && !bind_host.empty()) return bind_host;
  const auto names = local_names();
  for (const auto& n : names) {
    boost::system::error_code ec;
    const auto a = boost::asio::ip::make_address(n, ec);
    if (!ec && a.is_v4() && !a.is_loopback()) return n;
  }
  return names.size() > 2 ? names[2] : "127.0.0.1";  // the host name, or loopback
}

std::string phone_url(const std::string& host, unsigned port, const std::string& device_id,
                      const std::string& token) {
  // Unreserved characters (RFC 3986) stay; everything else is %XX.
  const auto encode = [](const std::string& s) {
    std::string out;
    for (unsigned char c : s) {
      if (std::isalnum(c) || c == '-' || c == '.' || c == '_' || c == '~') {
        out += char(c);
      } else {
        char buf[4];
        std::snprintf(buf, sizeof buf, "%%%02X", c);
        out += buf;
      }
    }
    return out;
  };
  const bool v6 = host.find(':') != std::string::npos;
  return "https://" + (v6 ? "[" + host + "]" : host) + ":" + std::to_string(port) +
         "/#device=" + encode(device_id) + "&token=" + encode(token);
}

std::vector<std::vector<bool>> qr_modules(const std::string& text) {
  QRcode* code = QRcode_encodeString8bit(text.c_str(), 0, QR_ECLEVEL_M);
  if (!code)
    throw InputError("the text of " + std::to_string(text.size()) +
                     " bytes does not fit a QR code");
  std::vector<std::vector<bool>> modules(std::size_t(code->width),
                                         std::vector<bool>(std::size_t(code->width)));
  for (int y = 0; y < code->width; ++y)
    for (int x = 0; x < code->width; ++x)
      modules[std::size_t(y)][std::size_t(x)] = code->data[y * code->width + x] & 1;
  QRcode_free(code);
  return modules;
}

std::string qr_terminal(const std::vector<std::vector<bool>>& modules, bool colour) {
  constexpr int kQuiet = 2;
  const int n = int(modules.size());
  const auto light = [&](int x, int y) {
    return x < 0 || y < 0 || x >= n || y >= n || !modules[std::size_t(y)][std::size_t(x)];
  };
  std::string out;
  for (int y = -kQuiet; y < n + kQuiet; y += 2) {
    if (colour) out += "\x1b[40;97m";  // bright white blocks on black
    for (int x = -kQuiet; x < n + kQuiet; ++x) {
      const bool top = light(x, y), bottom = light(x, y + 1);
      out += top && bottom ? "\u2588" : top ? "\u2580" : bottom ? "\u2584" : " ";
    }
    if (colour) out += "\x1b[0m";
    out += "\n";
  }
  return out;
}

std::string qr_svg(const std::vector<std::vector<bool>>& modules) {
  constexpr int kQuiet = 4;
  const int n = int(modules.size()), side = n + 2 * kQuiet;
  std::string path;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x)
      if (modules[std::size_t(y)][std::size_t(x)]) {
        path += 'M';
        path += std::to_string(x + kQuiet);
        path += ' ';
        path += std::to_string(y + kQuiet);
        path += "h1v1h-1z";
      }
  const std::string size = std::to_string(side);
  return "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 " + size + " " + size +
         "\" shape-rendering=\"crispEdges\"><rect width=\"" + size + "\" height=\"" + size +
         "\" fill=\"#fff\"/><path fill=\"#000\" d=\"" + path + "\"/></svg>\n";
}

std::string watch_link(std::string_view host, std::string_view query) {
  const auto allowed = [](std::string_view text, std::string_view extra) {
    return std::all_of(text.begin(), text.end(), [&](char c) {
      return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
             extra.find(c) != std::string_view::npos;
    });
  };
  constexpr std::string_view kWatch = "three=", kJoin = "join=";
  if (host.empty() || host.size() > 255 || !allowed(host, ".-:[]")) return "";
  const bool watch = query.substr(0, kWatch.size()) == kWatch;
  if (!watch && query.substr(0, kJoin.size()) != kJoin) return "";
  const std::string_view fragment = query.substr((watch ? kWatch : kJoin).size());
  if (fragment.empty() || fragment.size() > 512 || !allowed(fragment, "=&%._-~")) return "";
  return "https://" + std::string(host) + (watch ? "/three.html#" : "/#") + std::string(fragment);
}

}  // namespace arlight::daemon
