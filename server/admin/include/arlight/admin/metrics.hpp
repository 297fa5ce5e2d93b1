// A small thread-safe Prometheus metrics registry for arlightd's /metrics endpoint.
//
// Counters, gauges and histograms without labels, rendered in the Prometheus text exposition
// format 0.0.4 (https://prometheus.io/docs/instrumenting/exposition_formats/). Metrics are
// registered once by name and live as long as the registry; the references it hands out stay
// valid, so hot paths keep a `Counter&` and never look a name up again. Updating a metric is
// lock-free (counters, gauges) or takes one short uncontended lock (histograms).
#pragma once

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace arlight::admin {

// A monotonically increasing value (frames received, map computations, ...).
class Counter {
 public:
  // Adds v >= 0; a negative or NaN v throws std::invalid_argument (a counter never goes down).
  void inc(double v = 1);
  double value() const { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0.0};
};

// A value that goes up and down (open sessions, queue depth, ...).
class Gauge {
 public:
  void set(double v) { value_.store(v, std::memory_order_relaxed); }
  void add(double v) { value_.fetch_add(v, std::memory_order_relaxed); }
  double value() const { return value_.load(std::memory_order_relaxed); }

 private:
  std::atomic<double> value_{0.0};
};

// Observations counted into buckets with fixed upper bounds (latencies, sizes).
class Histogram {
 public:
  // upper_bounds: finite, strictly increasing (a trailing +Inf is accepted and dropped, since
  // the +Inf bucket always exists); anything else throws std::invalid_argument. An empty list
  // gives a histogram with only the +Inf bucket.
  explicit Histogram(std::vector<double> upper_bounds);

  // Counts v into the first bucket whose upper bound is >= v (Prometheus buckets are "le").
  // NaN observations are ignored: they would poison the sum forever.
  void observe(double v);

  struct Snapshot {
    std::vector<double> upper_bounds;       // as given, without +Inf
    std::vector<std::uint64_t> cumulative;  // upper_bounds.size() + 1; the last is +Inf == count
    double sum = 0;
    std::uint64_t count = 0;
  };
  // A consistent copy (taken under the histogram's lock): cumulative.back() == count.
  Snapshot snapshot() const;

  const std::vector<double>& upper_bounds() const { return bounds_; }

 private:
  std::vector<double> bounds_;
  mutable std::mutex mutex_;
  std::vector<std::uint64_t> buckets_;  // per-bucket (not cumulative), last is +Inf
  double sum_ = 0;
  std::uint64_t count_ = 0;
};

// True for a valid Prometheus metric name: [a-zA-Z_:][a-zA-Z0-9_:]*.
bool valid_metric_name(const std::string& name);

class Registry {
 public:
  Registry() = default;
  Registry(const Registry&) = delete;
  Registry& operator=(const Registry&) = delete;

  // Registers the metric on first use and returns it; the same name returns the same object
  // (its help text stays the first one given). Throws std::invalid_argument for an invalid
  // name, for a name already registered as another type (or as a histogram with other
  // bounds), and for a name that collides with a histogram's series (<h>_bucket, <h>_sum,
  // <h>_count).
  Counter& counter(const std::string& name, const std::string& help);
  Gauge& gauge(const std::string& name, const std::string& help);
  Histogram& histogram(const std::string& name, const std::string& help,
                       std::vector<double> upper_bounds);

  // Every metric in name order, in the text exposition format 0.0.4: "# HELP", "# TYPE", then
  // the samples; histograms as cumulative <name>_bucket{le="..."} lines ending with
  // le="+Inf", then <name>_sum and <name>_count.
  std::string render() const;

 private:
  enum class Type { kCounter, kGauge, kHistogram };
  struct Entry {
    Type type;
    std::string help;
    std::unique_ptr<Counter> counter;
    std::unique_ptr<Gauge> gauge;
    std::unique_ptr<Histogram> histogram;
  };
  static const char* type_name(Type t);
  // Finds `name` (checking its type) or returns nullptr after checking it may be added.
  Entry* find_or_check(const std::string& name, Type type);

  mutable std::mutex mutex_;
  std::map<std::string, Entry> entries_;
};

// A sample value as Prometheus writes it: shortest round-trip decimal, "+Inf", "-Inf", "NaN".
std::string format_metric_value(double v);

}  // namespace arlight::admin
