// Tests of arlight_admin: the Prometheus registry (exact exposition text, validation,
// concurrency) and the admin HTTP server (every route, status codes, content types, limits,
// keep-alive, isolation of a bad client, stop and shutdown).
#include <gtest/gtest.h>

#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/write.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <cctype>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "arlight/admin/admin_http.hpp"
#include "arlight/admin/metrics.hpp"

namespace {

using namespace arlight::admin;
namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;

// ---- metrics -------------------------------------------------------------------------------

TEST(Metrics, CounterAndGaugeText) {
  Registry r;
  Counter& c = r.counter("arlight_frames_received_total", "Frames received.");
  c.inc();
  c.inc(2.5);
  EXPECT_EQ(&c, &r.counter("arlight_frames_received_total", "ignored second help"));
  Gauge& g = r.gauge("arlight_sessions", "Open sessions.");
  g.set(3);
  g.add(-1);
  EXPECT_EQ(&g, &r.gauge("arlight_sessions", ""));
  EXPECT_EQ(c.value(), 3.5);
  EXPECT_EQ(g.value(), 2);
  EXPECT_EQ(r.render(),
            "# HELP arlight_frames_received_total Frames received.\n"
            "# TYPE arlight_frames_received_total counter\n"
            "arlight_frames_received_total 3.5\n"
            "# HELP arlight_sessions Open sessions.\n"
            "# TYPE arlight_sessions gauge\n"
            "arlight_sessions 2\n");
  EXPECT_THROW(c.inc(-1), std::invalid_argument);
  EXPECT_THROW(c.inc(std::nan("")), std::invalid_argument);
  EXPECT_EQ(c.value(), 3.5);
}

TEST(Metrics, HistogramExactText) {
  Registry r;
  Histogram& h = r.histogram("arlight_latency_seconds", "Frame to update latency.", {0.25, 0.5, 1});
  // le is inclusive: 0.25 counts in le="0.25", 0.5 twice in le="0.5"; 2 only in +Inf.
  for (double v : {0.25, 0.5, 0.5, 0.75, 2.0}) h.observe(v);
  h.observe(std::nan(""));  // ignored
  EXPECT_EQ(&h, &r.histogram("arlight_latency_seconds", "", {0.25, 0.5, 1}));
  EXPECT_EQ(r.render(),
            "# HELP arlight_latency_seconds Frame to update latency.\n"
            "# TYPE arlight_latency_seconds histogram\n"
            "arlight_latency_seconds_bucket{le=\"0.25\"} 1\n"
            "arlight_latency_seconds_bucket{le=\"0.5\"} 3\n"
            "arlight_latency_seconds_bucket{le=\"1\"} 4\n"
            "arlight_latency_seconds_bucket{le=\"+Inf\"} 5\n"
            "arlight_latency_seconds_sum 4\n"
            "arlight_latency_seconds_count 5\n");
  const Histogram::Snapshot s = h.snapshot();
  EXPECT_EQ(s.cumulative, (std::vector<std::uint64_t>{1, 3, 4, 5}));
  EXPECT_EQ(s.count, 5u);
  EXPECT_EQ(s.sum, 4.0);
}

TEST(Metrics, HistogramBoundsAndEmptyHistogram) {
  Registry r;
  // A trailing +Inf is the implicit bucket and is not repeated; observations below every
  // bound land in the first bucket.
  Histogram& h = r.histogram("h", "help", {1, std::numeric_limits<double>::infinity()});
  h.observe(-3);
  EXPECT_EQ(r.render(),
            "# HELP h help\n# TYPE h histogram\n"
            "h_bucket{le=\"1\"} 1\nh_bucket{le=\"+Inf\"} 1\nh_sum -3\nh_count 1\n");
  Registry only_inf;
  only_inf.histogram("e", "empty", {});
  EXPECT_EQ(only_inf.render(),
            "# HELP e empty\n# TYPE e histogram\ne_bucket{le=\"+Inf\"} 0\ne_sum 0\ne_count 0\n");
  EXPECT_THROW(Histogram({1, 1}), std::invalid_argument);
  EXPECT_THROW(Histogram({2, 1}), std::invalid_argument);
  EXPECT_THROW(Histogram({std::nan(""), 1}), std::invalid_argument);
  EXPECT_THROW(Histogram({-std::numeric_limits<double>::infinity(), 1}), std::invalid_argument);
  EXPECT_THROW(r.histogram("h", "other bounds", {1, 2}), std::invalid_argument);
}

TEST(Metrics, HelpIsEscaped) {
  Registry r;
  r.gauge("g", "back\\slash\nnew line");
  EXPECT_EQ(r.render(), "# HELP g back\\\\slash\\nnew line\n# TYPE g gauge\ng 0\n");
}

TEST(Metrics, InvalidNamesThrow) {
  Registry r;
  for (const char* bad : {"", "1abc", "a-b", "a b", "a.b", "caf\xc3\xa9", "x{y}", "\"q\""}) {
    EXPECT_THROW(r.counter(bad, "h"), std::invalid_argument) << bad;
    EXPECT_THROW(r.gauge(bad, "h"), std::invalid_argument) << bad;
    EXPECT_THROW(r.histogram(bad, "h", {1}), std::invalid_argument) << bad;
  }
  for (const char* good : {"a", "_x", ":x", "a:b_c9", "ABC_total"}) {
    EXPECT_NO_THROW(r.counter(good, "h")) << good;
  }
  EXPECT_EQ(r.render().find("1abc"), std::string::npos);
}

TEST(Metrics, NameConflictsThrow) {
  Registry r;
  r.counter("x", "h");
  EXPECT_THROW(r.gauge("x", "h"), std::invalid_argument);
  EXPECT_THROW(r.histogram("x", "h", {1}), std::invalid_argument);
  r.histogram("lat", "h", {1});
  EXPECT_THROW(r.counter("lat_count", "h"), std::invalid_argument);
  EXPECT_THROW(r.gauge("lat_sum", "h"), std::invalid_argument);
  EXPECT_THROW(r.gauge("lat_bucket", "h"), std::invalid_argument);
  r.gauge("size_sum", "h");
  EXPECT_THROW(r.histogram("size", "h", {1}), std::invalid_argument);
}

TEST(Metrics, ValueFormatting) {
  EXPECT_EQ(format_metric_value(0.1), "0.1");
  EXPECT_EQ(format_metric_value(42), "42");
  EXPECT_EQ(format_metric_value(-2.5), "-2.5");
  EXPECT_EQ(format_metric_value(1e6), "1e+06");
  EXPECT_EQ(format_metric_value(std::numeric_limits<double>::infinity()), "+Inf");
  EXPECT_EQ(format_metric_value(-std::numeric_limits<double>::infinity()), "-Inf");
  EXPECT_EQ(format_metric_value(std::nan("")), "NaN");
}

TEST(Metrics, ConcurrentUpdatesAreExact) {
  Registry r;
  constexpr int kThreads = 4;
  constexpr int kPerThread = 100000;
  std::atomic<bool> done{false};
  // Renders while the others write: a histogram's +Inf bucket must always equal its count.
  std::atomic<int> torn{0};
  std::atomic<int> renders{0};
  std::thread reader([&] {
    auto number_after = [](const std::string& text, const std::string& key) -> long long {
      const auto at = text.find(key);
      return at == std::string::npos ? -1 : std::stoll(text.substr(at + key.size()));
    };
    while (!done.load()) {
      const std::string text = r.render();
      const long long inf = number_after(text, "sizes_bucket{le=\"+Inf\"} ");
      if (inf != number_after(text, "sizes_count ")) ++torn;
      ++renders;
    }
  });
  std::vector<std::thread> writers;
  for (int t = 0; t < kThreads; ++t) {
    writers.emplace_back([&, t] {
      // Registration races too: every thread must get the same objects.
      Counter& c = r.counter("ops_total", "ops");
      Gauge& g = r.gauge("level", "level");
      Histogram& h = r.histogram("sizes", "sizes", {0.5, 1.5});
      for (int i = 0; i < kPerThread; ++i) {
        c.inc();
        g.add(t % 2 == 0 ? 2 : -1);
        h.observe(i % 2);
      }
    });
  }
  for (auto& w : writers) w.join();
  done = true;
  reader.join();
  EXPECT_EQ(torn.load(), 0);
  EXPECT_GT(renders.load(), 0);
  EXPECT_EQ(r.counter("ops_total", "").value(), kThreads * kPerThread);
  EXPECT_EQ(r.gauge("level", "").value(), kThreads / 2 * kPerThread);
  const Histogram::Snapshot s = r.histogram("sizes", "", {0.5, 1.5}).snapshot();
  EXPECT_EQ(s.count, std::uint64_t{kThreads} * kPerThread);
  EXPECT_EQ(s.cumulative[0], std::uint64_t{kThreads} * kPerThread / 2);
  EXPECT_EQ(s.cumulative[1], s.count);
  EXPECT_EQ(s.sum, kThreads * kPerThread / 2.0);
}

// ---- admin HTTP ----------------------------------------------------------------------------

constexpr const char* kToken = "a-test-admin-token-0123456789";

struct Reply {
  int status = 0;
  std::string content_type;
  std::string body;
  std::string allow;
  std::string www_authenticate;
  bool keep_alive = false;
};

// A tiny HTTP client on its own io_context; every exchange is bounded by a 5 s deadline so
// a misbehaving server fails the test instead of hanging it. Its requests carry
// `authorization` (by default the fixture's bearer token; "" for none).
class Client {
 public:
  explicit Client(std::uint16_t port, std::string authorization = std::string("Bearer ") + kToken)
      : stream_(ioc_), authorization_(std::move(authorization)) {
    stream_.expires_after(std::chrono::seconds(5));
    stream_.connect(tcp::endpoint(net::ip::address_v4::loopback(), port));
  }

  Reply request(http::verb verb, const std::string& target, const std::string& body = "") {
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1");
    if (!authorization_.empty()) req.set(http::field::authorization, authorization_);
    req.body() = body;
    req.prepare_payload();
    beast::error_code ec;
    http::response<http::string_body> res;
    stream_.expires_after(std::chrono::seconds(5));
    http::async_write(stream_, req, [&](beast::error_code wec, std::size_t) {
      if (wec) {
        ec = wec;
        return;
      }
      http::async_read(stream_, buffer_, res,
                       [&](beast::error_code rec, std::size_t) { ec = rec; });
    });
    run();
    if (ec) throw std::runtime_error("HTTP exchange for " + target + " failed: " + ec.message());
    return to_reply(res);
  }

  Reply get(const std::string& target) { return request(http::verb::get, target); }

  // Sends raw bytes; returns the error (empty if written).
  beast::error_code send_raw(const std::string& bytes) {
    beast::error_code ec;
    stream_.expires_after(std::chrono::seconds(5));
    net::async_write(stream_, net::buffer(bytes),
                     [&](beast::error_code wec, std::size_t) { ec = wec; });
    run();
    return ec;
  }

  // Reads one response; std::nullopt if the connection ended (EOF, reset) instead.
  std::optional<Reply> read_response() {
    beast::error_code ec;
    http::response<http::string_body> res;
    stream_.expires_after(std::chrono::seconds(5));
    http::async_read(stream_, buffer_, res, [&](beast::error_code rec, std::size_t) { ec = rec; });
    run();
    if (ec == beast::error::timeout) throw std::runtime_error("timed out reading a response");
    if (ec) return std::nullopt;
    return to_reply(res);
  }

  // True when the server closed the connection (a read ends with EOF or reset, not timeout).
  bool closed_by_server() {
    char byte;
    beast::error_code ec;
    stream_.expires_after(std::chrono::seconds(5));
    stream_.async_read_some(net::buffer(&byte, 1),
                            [&](beast::error_code rec, std::size_t) { ec = rec; });
    run();
    return ec && ec != beast::error::timeout;
  }

 private:
  void run() {
    ioc_.restart();
    ioc_.run();
  }
  static Reply to_reply(const http::response<http::string_body>& res) {
    Reply r;
    r.status = res.result_int();
    r.content_type = std::string(res[http::field::content_type]);
    r.allow = std::string(res[http::field::allow]);
    r.www_authenticate = std::string(res[http::field::www_authenticate]);
    r.body = res.body();
    r.keep_alive = res.keep_alive();
    return r;
  }

  net::io_context ioc_;
  beast::tcp_stream stream_;
  std::string authorization_;
  beast::flat_buffer buffer_;
};

const std::vector<std::uint8_t> kPng = {0x89, 'P',  'N',  'G',  '\r', '\n', 0x1a, '\n',
                                        0x00, 0xff, 0x00, 0x7f, 'I',  'E',  'N',  'D'};

class AdminServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    registry.counter("arlight_frames_received_total", "Frames received.").inc(7);
    AdminHandlers h;
    h.metrics = [this] { return registry.render(); };
    h.sessions_json = [this]() -> std::string {
      ++calls;
      if (sessions_throw) throw std::runtime_error("session table unavailable");
      return R"([{"id":"abc-123","frames":7}])";
    };
    h.envmap_png = [this](const std::string& id) -> std::optional<std::vector<std::uint8_t>> {
      ++calls;
      std::lock_guard lock(ids_mutex);
      requested_ids.push_back(id);
      if (id == "abc-123") return kPng;
      return std::nullopt;
    };
    h.light_file = [this](const std::string& id, AdminHandlers::LightFile file) -> std::optional<std::string> {
      ++calls;
      if (id == "no-frames") throw NotReady("session 'no-frames' has no map yet");
      if (id != "abc-123") return std::nullopt;
      return file == AdminHandlers::LightFile::Json ? std::string(R"({"sh9":{}})")
                                                    : std::string("\xabKTX 20\xbb\r\n\x1a\n\0\0", 14);
    };
    h.healthy = [this] { return healthy.load(); };
    server = std::make_unique<AdminServer>(io, "127.0.0.1", 0, std::move(h),
                                           AdminAccess{kToken, protect_all});
    port = server->port();
    server->start();
    for (int i = 0; i < 2; ++i) threads.emplace_back([this] { io.run(); });
  }

  void TearDown() override {
    server.reset();
    work.reset();
    io.stop();
    for (auto& t : threads) t.join();
  }

  bool protect_all = false;  // set by a derived fixture before SetUp
  Registry registry;
  std::atomic<bool> healthy{true};
  std::atomic<bool> sessions_throw{false};
  std::atomic<int> calls{0};
  std::mutex ids_mutex;
  std::vector<std::string> requested_ids;

  net::io_context io;
  std::optional<net::executor_work_guard<net::io_context::executor_type>> work{
      net::make_work_guard(io)};
  std::vector<std::thread> threads;
  std::unique_ptr<AdminServer> server;
  std::uint16_t port = 0;
};

TEST_F(AdminServerTest, BindsAnEphemeralPort) { EXPECT_NE(port, 0); }

TEST_F(AdminServerTest, Healthz) {
  Client c(port);
  Reply r = c.get("/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.body, "ok\n");
  EXPECT_EQ(r.content_type.rfind("text/plain", 0), 0u) << r.content_type;
  healthy = false;
  r = c.get("/healthz");
  EXPECT_EQ(r.status, 503);
  EXPECT_NE(r.body, "ok\n");
}

TEST_F(AdminServerTest, Metrics) {
  Reply r = Client(port).get("/metrics");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "text/plain; version=0.0.4");
  EXPECT_EQ(r.body, registry.render());
  EXPECT_NE(r.body.find("arlight_frames_received_total 7\n"), std::string::npos) << r.body;
}

TEST_F(AdminServerTest, SessionsJson) {
  Reply r = Client(port).get("/sessions");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "application/json");
  EXPECT_EQ(r.body, R"([{"id":"abc-123","frames":7}])");
}

TEST_F(AdminServerTest, EnvmapPngAndUnknownSession) {
  Client c(port);
  Reply r = c.get("/sessions/abc-123/envmap.png");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "image/png");
  EXPECT_EQ(r.body, std::string(kPng.begin(), kPng.end()));  // binary-safe, NULs included
  r = c.get("/sessions/no-such-session/envmap.png");
  EXPECT_EQ(r.status, 404);
  EXPECT_EQ(r.content_type.rfind("text/plain", 0), 0u);
  EXPECT_NE(r.body.find("no-such-session"), std::string::npos) << r.body;
}

TEST_F(AdminServerTest, LightFilesOfASession) {
  Client c(port);
  Reply r = c.get("/sessions/abc-123/light.json");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "application/json");
  EXPECT_EQ(r.body, R"({"sh9":{}})");
  r = c.get("/sessions/abc-123/specular.ktx2");
  EXPECT_EQ(r.status, 200);
  EXPECT_EQ(r.content_type, "image/ktx2");
  EXPECT_EQ(r.body, std::string("\xabKTX 20\xbb\r\n\x1a\n\0\0", 14));  // binary-safe
  EXPECT_EQ(c.get("/sessions/nope/specular.ktx2").status, 404);
  EXPECT_EQ(c.get("/sessions/a.b/light.json").status, 400);
  EXPECT_EQ(c.get("/sessions/abc-123/light.jsonx").status, 404);
  r = c.get("/sessions/no-frames/light.json");
  EXPECT_EQ(r.status, 409);
  EXPECT_EQ(r.body, "session 'no-frames' has no map yet\n");
}

TEST_F(AdminServerTest, BadSessionIdsAre400AndNeverReachTheHandler) {
  Client c(port);
  const std::vector<std::string> bad = {
      "..%2F", "..", "a.b", "a/b", "a%20b", "a_b", std::string(129, 'a')};
  for (const std::string& id : bad) {
    EXPECT_EQ(c.get("/sessions/" + id + "/envmap.png").status, 400) << id;
  }
  EXPECT_EQ(c.get("/sessions/" + std::string(128, 'a') + "/envmap.png").status, 404);
  std::lock_guard lock(ids_mutex);
  EXPECT_EQ(requested_ids, std::vector<std::string>{std::string(128, 'a')});
}

TEST_F(AdminServerTest, WithoutTheRightTokenARoomIs401AndNothingElse) {
  const std::string id_ok = "/sessions/abc-123/envmap.png";
  const std::string wrong_same_length(std::string(kToken).size(), 'x');
  for (const std::string& auth :
       {std::string(), "Bearer " + wrong_same_length, std::string("Bearer ") + kToken + "x",
        std::string("Bearer ") + std::string(kToken).substr(1), std::string("Basic ") + kToken,
        std::string("Bearer"), std::string("Bearer  "), std::string(kToken)}) {
    Client c(port, auth);
    for (const std::string& target : {std::string("/sessions"), id_ok,
                                      std::string("/sessions/../envmap.png")}) {
      const Reply r = c.get(target);
      EXPECT_EQ(r.status, 401) << "'" << auth << "' " << target;
      EXPECT_EQ(r.body, "unauthorized\n");
      EXPECT_EQ(r.www_authenticate.rfind(R"(Bearer realm="arlightd-admin")", 0), 0u)
          << r.www_authenticate;
      EXPECT_TRUE(r.keep_alive);  // the same connection may try again
    }
    // The health and metrics routes stay open by default (Prometheus and probes scrape them).
    EXPECT_EQ(c.get("/healthz").status, 200);
    EXPECT_EQ(c.get("/metrics").status, 200);
  }
  // A wrong token is told it was invalid (RFC 6750); a missing one only gets the challenge.
  EXPECT_NE(Client(port, "Bearer " + wrong_same_length).get("/sessions").www_authenticate.find(
                "invalid_token"),
            std::string::npos);
  EXPECT_EQ(Client(port, "").get("/sessions").www_authenticate.find("error"), std::string::npos);
  EXPECT_EQ(calls.load(), 0);  // no handler ever ran
  // The scheme is case-insensitive; the token is not.
  EXPECT_EQ(Client(port, std::string("bearer ") + kToken).get(id_ok).status, 200);
  std::string upper = kToken;
  for (char& ch : upper) ch = char(std::toupper(static_cast<unsigned char>(ch)));
  EXPECT_EQ(Client(port, "Bearer " + upper).get(id_ok).status, 401);
}

class AdminServerProtectAllTest : public AdminServerTest {
 protected:
  void SetUp() override {
    protect_all = true;
    AdminServerTest::SetUp();
  }
};

TEST_F(AdminServerProtectAllTest, HealthAndMetricsNeedTheTokenToo) {
  Client none(port, "");
  EXPECT_EQ(none.get("/healthz").status, 401);
  EXPECT_EQ(none.get("/metrics").status, 401);
  Client with(port);
  EXPECT_EQ(with.get("/healthz").status, 200);
  EXPECT_EQ(with.get("/metrics").status, 200);
  EXPECT_EQ(with.get("/sessions").status, 200);
}

TEST_F(AdminServerTest, UnknownPathsAndMethods) {
  Client c(port);
  EXPECT_EQ(c.get("/").status, 404);
  EXPECT_EQ(c.get("/metricsx").status, 404);
  EXPECT_EQ(c.get("/sessions/abc-123").status, 404);
  EXPECT_EQ(c.get("/sessions/abc-123/other.png").status, 404);
  EXPECT_EQ(c.get("/healthz?verbose=1").status, 200);  // queries are ignored
  Reply r = c.request(http::verb::post, "/metrics");
  EXPECT_EQ(r.status, 405);
  EXPECT_EQ(r.allow, "GET");
  EXPECT_TRUE(r.keep_alive);  // no body: the connection carries on
  EXPECT_EQ(c.request(http::verb::delete_, "/sessions").status, 405);
  EXPECT_EQ(c.request(http::verb::head, "/healthz").status, 405);
  EXPECT_EQ(c.get("/healthz").status, 200);
  // A request with a body is refused and the connection closed (the body is never read).
  r = c.request(http::verb::post, "/sessions", "{\"x\":1}");
  EXPECT_EQ(r.status, 405);
  EXPECT_FALSE(r.keep_alive);
  EXPECT_TRUE(c.closed_by_server());
  Client d(port);
  r = d.request(http::verb::get, "/healthz", "body");
  EXPECT_EQ(r.status, 413);
  EXPECT_TRUE(d.closed_by_server());
  EXPECT_EQ(calls.load(), 0);
}

TEST_F(AdminServerTest, KeepAliveServesManyRequestsOnOneConnection) {
  Client c(port);
  for (int i = 0; i < 5; ++i) {
    Reply r = c.get(i % 2 ? "/sessions" : "/healthz");
    EXPECT_EQ(r.status, 200);
    EXPECT_TRUE(r.keep_alive);
  }
}

TEST_F(AdminServerTest, HandlerExceptionIs500WithTheMessage) {
  sessions_throw = true;
  Client c(port);
  Reply r = c.get("/sessions");
  EXPECT_EQ(r.status, 500);
  EXPECT_NE(r.body.find("session table unavailable"), std::string::npos) << r.body;
  sessions_throw = false;
  EXPECT_EQ(c.get("/sessions").status, 200);  // the same connection carries on
}

TEST_F(AdminServerTest, OversizedHeaderOnlyHurtsItsOwnConnection) {
  Client bad(port);
  const std::string start = "GET /healthz HTTP/1.1\r\nHost: 127.0.0.1\r\nX-Big: ";
  ASSERT_FALSE(bad.send_raw(start + std::string(6 * 1024, 'a')));  // under the limit so far
  // Meanwhile other connections, including one that sends nothing at all, are unaffected.
  Client idle(port);
  Reply good = Client(port).get("/healthz");
  EXPECT_EQ(good.status, 200);
  // The rest of the 20 KiB header: 431, or the connection dropped while we were still writing.
  const beast::error_code wec = bad.send_raw(std::string(14 * 1024, 'a') + "\r\n\r\n");
  std::optional<Reply> r = bad.read_response();
  if (r) {
    EXPECT_EQ(r->status, 431);
    EXPECT_FALSE(r->keep_alive);
  } else {
    SUCCEED() << "connection closed (write: " << wec.message() << ")";
  }
  EXPECT_EQ(Client(port).get("/metrics").status, 200);
}

TEST_F(AdminServerTest, GarbageIs400AndClosed) {
  Client c(port);
  ASSERT_FALSE(c.send_raw("NOT AN HTTP REQUEST\r\n\r\n"));
  std::optional<Reply> r = c.read_response();
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 400);
  EXPECT_TRUE(c.closed_by_server());
  EXPECT_EQ(Client(port).get("/healthz").status, 200);
}

TEST_F(AdminServerTest, ConcurrentClients) {
  std::atomic<int> ok{0};
  std::vector<std::thread> clients;
  for (int t = 0; t < 8; ++t) {
    clients.emplace_back([&] {
      Client c(port);
      for (int i = 0; i < 20; ++i) {
        if (c.get("/sessions/abc-123/envmap.png").status == 200) ++ok;
      }
    });
  }
  for (auto& t : clients) t.join();
  EXPECT_EQ(ok.load(), 160);
}

TEST_F(AdminServerTest, SecondServerOnTheSamePortNamesTheAddress) {
  try {
    AdminServer other(io, "127.0.0.1", port, {});
    FAIL() << "binding a used port succeeded";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("127.0.0.1:" + std::to_string(port)), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(AdminServer(io, "no.such.host.invalid", 0, {}), std::runtime_error);
}

TEST_F(AdminServerTest, StopClosesTheAcceptorAndEndsKeepAlive) {
  Client open(port);
  EXPECT_EQ(open.get("/healthz").status, 200);
  server->stop();
  server->stop();  // idempotent
  // The open connection finishes its next request, then is closed instead of kept alive.
  Reply r = open.get("/healthz");
  EXPECT_EQ(r.status, 200);
  EXPECT_FALSE(r.keep_alive);
  EXPECT_TRUE(open.closed_by_server());
  EXPECT_THROW(Client{port}, boost::system::system_error);  // connection refused
}

TEST_F(AdminServerTest, NoHandlerRunsAfterDestruction) {
  Client open(port);
  EXPECT_EQ(open.get("/sessions").status, 200);
  const int before = calls.load();
  server.reset();
  Reply r = open.get("/sessions");
  EXPECT_EQ(r.status, 503);
  EXPECT_FALSE(r.keep_alive);
  EXPECT_EQ(calls.load(), before);
}

TEST(AdminServer, WithoutAConfiguredTokenRoomsAre403) {
  net::io_context io;
  AdminServer server(io, "127.0.0.1", 0, {});
  server.start();
  std::thread t([&] { io.run_for(std::chrono::seconds(3)); });
  {
    Client c(server.port());
    EXPECT_EQ(c.get("/healthz").status, 200);
    EXPECT_EQ(c.get("/sessions").status, 403);
    EXPECT_EQ(c.get("/sessions/x/envmap.png").status, 403);
    EXPECT_EQ(Client(server.port(), "Bearer ").get("/sessions").status, 403);
  }
  server.stop();
  io.stop();
  t.join();
}

TEST(AdminServer, EmptyHandlersAre501AndHealthy) {
  net::io_context io;
  AdminServer server(io, "127.0.0.1", 0, {}, {kToken});
  server.start();
  std::thread t([&] { io.run_for(std::chrono::seconds(3)); });
  {
    Client c(server.port());
    EXPECT_EQ(c.get("/healthz").status, 200);
    EXPECT_EQ(c.get("/metrics").status, 501);
    EXPECT_EQ(c.get("/sessions").status, 501);
    EXPECT_EQ(c.get("/sessions/x/envmap.png").status, 501);
  }
  server.stop();
  io.stop();
  t.join();
}

}  // namespace
