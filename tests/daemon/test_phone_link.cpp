// The phone link: the URL a phone opens, its QR code as the terminal shows it (read back with
// ZBar, as a phone's camera app would), the self-signed certificate kept in the data folder, and
// which files the web port serves.
#include <gtest/gtest.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>
#include <zbar.h>

#include <fstream>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "arlight/daemon/daemon.hpp"
#include "phone_link.hpp"
#include "web_server.hpp"

namespace fs = std::filesystem;
using namespace arlight;
using namespace arlight::daemon;

namespace {

fs::path fresh_dir(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("arlight_" + name + "_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// The terminal text back into modules: each character is two module rows (upper, lower half),
// drawn halves are light. Then an image a camera might see, 8 pixels a module.
cv::Mat render_terminal_qr(const std::string& text) {
  std::vector<std::vector<bool>> light_rows;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    std::vector<bool> top, bottom;
    for (std::size_t i = 0; i < line.size();) {
      if (line[i] == ' ') {
        top.push_back(false), bottom.push_back(false), ++i;
        continue;
      }
      const std::string ch = line.substr(i, 3);  // the half blocks are 3 bytes of UTF-8
      i += 3;
      top.push_back(ch == "\u2588" || ch == "\u2580");
      bottom.push_back(ch == "\u2588" || ch == "\u2584");
    }
    light_rows.push_back(top), light_rows.push_back(bottom);
  }
  const int h = int(light_rows.size()), w = int(light_rows.front().size()), s = 8;
  cv::Mat img(h * s, w * s, CV_8U, cv::Scalar(255));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x)
      if (!light_rows[std::size_t(y)][std::size_t(x)]) img(cv::Rect(x * s, y * s, s, s)).setTo(0);
  cv::Mat padded;
  cv::copyMakeBorder(img, padded, 32, 32, 32, 32, cv::BORDER_CONSTANT, cv::Scalar(255));
  return padded;
}

// What a QR reader makes of the picture (ZBar; Debian's OpenCV has no QR decoder).
std::string decode_qr(const cv::Mat& gray) {
  zbar::ImageScanner scanner;
  scanner.set_config(zbar::ZBAR_NONE, zbar::ZBAR_CFG_ENABLE, 0);
  scanner.set_config(zbar::ZBAR_QRCODE, zbar::ZBAR_CFG_ENABLE, 1);
  zbar::Image image(unsigned(gray.cols), unsigned(gray.rows), "Y800", gray.data,
                    unsigned(gray.total()));
  if (scanner.scan(image) <= 0) return {};
  return image.symbol_begin()->get_data();
}

// The SVG's path ("M x y h1v1h-1z" a dark module) drawn as a camera might see it, 8 pixels a unit.
cv::Mat render_svg_qr(const std::string& svg) {
  const std::size_t box = svg.find("viewBox=\"0 0 ") + 13;
  const int side = std::stoi(svg.substr(box));
  const int s = 8;
  cv::Mat img(side * s, side * s, CV_8U, cv::Scalar(255));
  const std::string path = svg.substr(svg.find(" d=\"") + 4);
  std::istringstream in(path);
  char m;
  int x, y;
  while (in >> m && m == 'M' && in >> x >> y) {
    img(cv::Rect(x * s, y * s, s, s)).setTo(0);
    in.ignore(8);  // h1v1h-1z
  }
  return img;
}

}  // namespace

TEST(PhoneLink, TheWatchLinksQrCodeIsAnSvgThatDecodesToTheLink) {
  const std::string link = watch_link("192.168.1.20:8443", "three=session%3Dabc&device=phone&token=t-1");
  EXPECT_EQ(link, "https://192.168.1.20:8443/three.html#session%3Dabc&device=phone&token=t-1");
  const std::string svg = qr_svg(qr_modules(link));
  EXPECT_EQ(svg.rfind("<svg xmlns=\"http://www.w3.org/2000/svg\"", 0), 0u);
  EXPECT_EQ(decode_qr(render_svg_qr(svg)), link);
  // Only such links: no other parameter, host or characters (no markup, no other URL).
  EXPECT_EQ(watch_link("host", "text=https://evil.example/"), "");
  EXPECT_EQ(watch_link("host", "three=<script>"), "");
  EXPECT_EQ(watch_link("host", "three=" + std::string(513, 'a')), "");
  EXPECT_EQ(watch_link("evil.example/x?", "three=a"), "");
  EXPECT_EQ(watch_link("", "three=a"), "");
  // The join link (issue 49): the phone page itself, capturing into the session.
  const std::string join = watch_link("192.168.1.20:8443", "join=device=phone-b&token=00ff&join=abc");
  EXPECT_EQ(join, "https://192.168.1.20:8443/#device=phone-b&token=00ff&join=abc");
  EXPECT_EQ(decode_qr(render_svg_qr(qr_svg(qr_modules(join)))), join);
  EXPECT_EQ(watch_link("host", "join=<script>"), "");
  EXPECT_EQ(watch_link("host", "joined=a"), "");
}

TEST(PhoneLink, UrlCarriesDeviceAndTokenInTheFragmentEncoded) {
  EXPECT_EQ(phone_url("192.168.1.20", 8443, "phone", "abc123"),
            "https://192.168.1.20:8443/#device=phone&token=abc123");
  // Anything outside the unreserved set is percent-encoded, so a token cannot end the fragment
  // or add a parameter.
  EXPECT_EQ(phone_url("host", 1, "my phone", "a&b=c#d"),
            "https://host:1/#device=my%20phone&token=a%26b%3Dc%23d");
  EXPECT_EQ(phone_url("fe80::1", 8443, "d", "t"), "https://[fe80::1]:8443/#device=d&token=t");
}

TEST(PhoneLink, TheTerminalQrCodeDecodesToTheUrl) {
  const std::string url = phone_url("192.168.1.20", 8443, "phone-7", "Zq8-token_0123456789");
  const auto modules = qr_modules(url);
  ASSERT_GE(modules.size(), 21u);     // version 1 is 21 modules
  EXPECT_EQ(modules.size() % 4, 1u);  // 17 + 4 * version
  for (const bool colour : {false, true}) {
    const std::string text = qr_terminal(modules, colour);
    if (colour) {
      EXPECT_NE(text.find("\x1b[40;97m"), std::string::npos);
      continue;  // the colours wrap the same characters
    }
    const cv::Mat img = render_terminal_qr(text);
    EXPECT_EQ(decode_qr(img), url);
  }
  EXPECT_THROW(qr_modules(std::string(8000, 'x')), InputError);
}

TEST(PhoneLink, SelfSignedCertificateNamesTheHostsAndIsKeptAcrossRestarts) {
  const fs::path dir = fresh_dir("selfsigned");
  const std::vector<std::string> names = {"localhost", "127.0.0.1", "192.0.2.7"};
  const CertificateFiles first = ensure_self_signed_certificate(dir, names);
  EXPECT_TRUE(first.created);
  struct stat st {};
  ASSERT_EQ(stat(first.key.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u) << "the private key must be readable by its owner alone";

  FILE* f = std::fopen(first.cert.c_str(), "r");
  X509* x = PEM_read_X509(f, nullptr, nullptr, nullptr);
  std::fclose(f);
  ASSERT_TRUE(x);
  EXPECT_EQ(X509_check_host(x, "localhost", 0, 0, nullptr), 1);
  EXPECT_EQ(X509_check_ip_asc(x, "192.0.2.7", 0), 1);
  EXPECT_EQ(X509_check_ip_asc(x, "127.0.0.1", 0), 1);
  EXPECT_NE(X509_check_ip_asc(x, "192.0.2.8", 0), 1);
  EXPECT_EQ(X509_check_purpose(x, X509_PURPOSE_SSL_SERVER, 0), 1);
  // Valid now and for more than two years.
  time_t in_two_years = time(nullptr) + 2 * 365 * 86400;
  EXPECT_GT(X509_cmp_time(X509_get0_notAfter(x), &in_two_years), 0);
  EXPECT_LT(X509_cmp_current_time(X509_get0_notBefore(x)), 0);
  X509_free(x);

  const auto read = [](const fs::path& p) {
    std::ifstream in(p);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string pem = read(first.cert);
  // The same names again: the same certificate (a phone accepted it once).
  const CertificateFiles again = ensure_self_signed_certificate(dir, names);
  EXPECT_FALSE(again.created);
  EXPECT_EQ(read(again.cert), pem);
  // Another address (the machine moved networks): a new one that names it.
  auto moved = names;
  moved.back() = "192.0.2.9";
  EXPECT_TRUE(ensure_self_signed_certificate(dir, moved).created);
  EXPECT_NE(read(first.cert), pem);
  // A damaged file is replaced, not served.
  std::ofstream(first.cert) << "not a certificate";
  EXPECT_TRUE(ensure_self_signed_certificate(dir, moved).created);
}

TEST(PhoneLink, ReachableHostIsTheBoundAddressOrALanAddress) {
  EXPECT_EQ(reachable_host("10.1.2.3"), "10.1.2.3");
  const std::string any = reachable_host("0.0.0.0");
  EXPECT_FALSE(any.empty());
  EXPECT_NE(any, "0.0.0.0");
  const auto names = local_names();
  EXPECT_NE(std::find(names.begin(), names.end(), any), names.end()) << any;
}

TEST(WebServer, ServesOnlyPlainFilesUnderTheRoot) {
  const fs::path dir = fresh_dir("webroot");
  fs::create_directories(dir / "root" / "assets");
  std::ofstream(dir / "root" / "index.html") << "<!doctype html>";
  std::ofstream(dir / "root" / "assets" / "app.wasm") << "wasm";
  std::ofstream(dir / "root" / ".secret") << "x";
  std::ofstream(dir / "outside.txt") << "x";
  const fs::path root = dir / "root";
  EXPECT_EQ(resolve_static_file(root, "/").path, root / "index.html");
  EXPECT_EQ(resolve_static_file(root, "/index.html?v=3").path, root / "index.html");
  EXPECT_EQ(resolve_static_file(root, "/assets/app.wasm").path, root / "assets" / "app.wasm");
  for (const char* bad :
       {"/../outside.txt", "/assets/../../outside.txt", "/.secret", "/assets//app.wasm", "/assets/",
        "/%2e%2e/outside.txt", "/missing.js", "/assets", "/index.html/"})
    EXPECT_FALSE(resolve_static_file(root, bad).path) << bad;
  EXPECT_EQ(resolve_static_file(root, "index.html").status, 400);
  EXPECT_EQ(resolve_static_file(root, "/nope").status, 404);
  EXPECT_STREQ(content_type("a/b.wasm"), "application/wasm");
  EXPECT_STREQ(content_type("x.js"), "text/javascript; charset=utf-8");
  EXPECT_STREQ(content_type("x.unknown"), "application/octet-stream");
  // Only the tracking worker (opencv.js) may evaluate strings; the page may not.
  const std::string page = content_security_policy(root / "index.html");
  const std::string worker = content_security_policy(root / "marker_worker.js");
  EXPECT_EQ(page.find("'unsafe-eval'"), std::string::npos);
  EXPECT_EQ(std::string(content_security_policy(root / "app.js")), page);
  // An import map (inline by necessity) is allowed by its hash, and nothing else inline is.
  const std::string map = R"({"imports": {"three": "./three/lib/three.module.js"}})";
  std::ofstream(root / "three.html") << "<!doctype html><script type=\"importmap\">" << map
                                     << "</script><script type=\"module\" src=\"p.js\"></script>";
  const std::string three = content_security_policy(root / "three.html");
  // echo -n '{"imports": {"three": "./three/lib/three.module.js"}}' | openssl dgst -sha256 -binary | base64
  EXPECT_NE(three.find("script-src 'self' 'sha256-2ms9co1BQoGYrEopSc7gxYwCoasehyP8N9pIFA8dBX8='"),
            std::string::npos)
      << three;
  EXPECT_EQ(three.find("'unsafe-inline'", three.find("script-src")),
            three.find("'unsafe-inline'", three.find("style-src")));
  EXPECT_NE(worker.find("'unsafe-eval'"), std::string::npos);
  EXPECT_NE(worker.find("connect-src 'self'"), std::string::npos);
}

TEST(WebConfig, TheConfigFileTurnsTheWebPortOnAndNamesBadValues) {
  const fs::path dir = fresh_dir("webconfig");
  std::ofstream(dir / "on.json") << R"({"web": "0.0.0.0:8443", "web_device": "phone",
                                        "web_url_host": "ar.example", "web_root": "/srv/web"})";
  DaemonConfig c;
  load_config_file(dir / "on.json", c);
  EXPECT_TRUE(c.web_enabled);
  EXPECT_EQ(c.web_host, "0.0.0.0");
  EXPECT_EQ(c.web_port, 8443);
  EXPECT_EQ(c.web_device, "phone");
  EXPECT_EQ(c.web_url_host, "ar.example");
  EXPECT_EQ(c.web_root, "/srv/web");
  // The example file leaves it off.
  DaemonConfig example;
  load_config_file(fs::path(ARLIGHT_SOURCE_DIR) / "deploy" / "arlightd.example.json", example);
  EXPECT_FALSE(example.web_enabled);
  std::ofstream(dir / "bad.json") << R"({"web": "8443"})";
  try {
    load_config_file(dir / "bad.json", c);
    FAIL() << "a web address without a host was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("web"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("HOST:PORT"), std::string::npos) << e.what();
  }
}
