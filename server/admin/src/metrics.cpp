#include "arlight/admin/metrics.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <system_error>

namespace arlight::admin {

namespace {

bool name_start(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' || c == ':';
}
bool name_char(char c) { return name_start(c) || (c >= '0' && c <= '9'); }

void check_name(const std::string& name) {
  if (!valid_metric_name(name)) {
    throw std::invalid_argument("metrics: invalid metric name '" + name +
                                "' (must match [a-zA-Z_:][a-zA-Z0-9_:]*)");
  }
}

// "# HELP" text escapes backslash and line feed (exposition format 0.0.4).
std::string escape_help(const std::string& help) {
  std::string out;
  out.reserve(help.size());
  for (char c : help) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

bool valid_metric_name(const std::string& name) {
  if (name.empty() || !name_start(name[0])) return false;
  return std::all_of(name.begin() + 1, name.end(), name_char);
}

std::string format_metric_value(double v) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "+Inf" : "-Inf";
  char buf[64];
  auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);  // shortest round-trip form
  if (ec != std::errc()) return "NaN";  // cannot happen with 64 chars; never emit garbage
  return std::string(buf, end);
}

// ---- Counter -------------------------------------------------------------------------------

void Counter::inc(double v) {
  if (!(v >= 0)) {  // also catches NaN
    throw std::invalid_argument("metrics: counter increment must be >= 0, got " +
                                format_metric_value(v));
  }
  value_.fetch_add(v, std::memory_order_relaxed);
}

// ---- Histogram -----------------------------------------------------------------------------

Histogram::Histogram(std::vector<double> upper_bounds) : bounds_(std::move(upper_bounds)) {
  if (!bounds_.empty() && std::isinf(bounds_.back()) && bounds_.back() > 0) bounds_.pop_back();
  for (std::size_t i = 0; i < bounds_.size(); ++i) {
    if (!std::isfinite(bounds_[i])) {
      throw std::invalid_argument("metrics: histogram bucket bound #" + std::to_string(i) + " is " +
                                  format_metric_value(bounds_[i]) +
                                  " (bounds must be finite; +Inf only last)");
    }
    if (i > 0 && !(bounds_[i] > bounds_[i - 1])) {
      throw std::invalid_argument("metrics: histogram bucket bounds must increase strictly, but #" +
                                  std::to_string(i) + " (" + format_metric_value(bounds_[i]) +
                                  ") follows " + format_metric_value(bounds_[i - 1]));
    }
  }
  buckets_.assign(bounds_.size() + 1, 0);
}

void Histogram::observe(double v) {
  if (std::isnan(v)) return;
  // First bound >= v; v above every bound lands in the +Inf bucket (index bounds_.size()).
  const auto idx = static_cast<std::size_t>(std::lower_bound(bounds_.begin(), bounds_.end(), v) -
                                            bounds_.begin());
  std::lock_guard lock(mutex_);
  ++buckets_[idx];
  sum_ += v;
  ++count_;
}

Histogram::Snapshot Histogram::snapshot() const {
  Snapshot s;
  s.upper_bounds = bounds_;
  s.cumulative.resize(bounds_.size() + 1);
  std::lock_guard lock(mutex_);
  std::uint64_t running = 0;
  for (std::size_t i = 0; i < buckets_.size(); ++i) {
    running += buckets_[i];
    s.cumulative[i] = running;
  }
  s.sum = sum_;
  s.count = count_;
  return s;
}

// ---- Registry ------------------------------------------------------------------------------

const char* Registry::type_name(Type t) {
  switch (t) {
    case Type::kCounter:
      return "counter";
    case Type::kGauge:
      return "gauge";
    case Type::kHistogram:
      break;
  }
  return "histogram";
}

Registry::Entry* Registry::find_or_check(const std::string& name, Type type) {
  check_name(name);
  if (auto it = entries_.find(name); it != entries_.end()) {
    if (it->second.type != type) {
      throw std::invalid_argument("metrics: '" + name + "' is already registered as a " +
                                  type_name(it->second.type) + ", not a " + type_name(type));
    }
    return &it->second;
  }
  // A new name must not collide with the series a histogram writes (<h>_bucket, _sum, _count),
  // in either direction; otherwise the exposition would hold two metrics with one name.
  static constexpr const char* kSuffixes[] = {"_bucket", "_sum", "_count"};
  for (const char* suffix : kSuffixes) {
    const std::string s = suffix;
    if (name.size() > s.size() && name.compare(name.size() - s.size(), s.size(), s) == 0) {
      auto base = entries_.find(name.substr(0, name.size() - s.size()));
      if (base != entries_.end() && base->second.type == Type::kHistogram) {
        throw std::invalid_argument("metrics: '" + name + "' collides with histogram '" +
                                    base->first + "'");
      }
    }
    if (type == Type::kHistogram && entries_.count(name + s) != 0) {
      throw std::invalid_argument("metrics: histogram '" + name + "' collides with '" + name + s +
                                  "'");
    }
  }
  return nullptr;
}

Counter& Registry::counter(const std::string& name, const std::string& help) {
  std::lock_guard lock(mutex_);
  if (Entry* e = find_or_check(name, Type::kCounter)) return *e->counter;
  Entry& e = entries_[name];
  e.type = Type::kCounter;
  e.help = help;
  e.counter = std::make_unique<Counter>();
  return *e.counter;
}

Gauge& Registry::gauge(const std::string& name, const std::string& help) {
  std::lock_guard lock(mutex_);
  if (Entry* e = find_or_check(name, Type::kGauge)) return *e->gauge;
  Entry& e = entries_[name];
  e.type = Type::kGauge;
  e.help = help;
  e.gauge = std::make_unique<Gauge>();
  return *e.gauge;
}

Histogram& Registry::histogram(const std::string& name, const std::string& help,
                               std::vector<double> upper_bounds) {
  auto h = std::make_unique<Histogram>(std::move(upper_bounds));  // validates the bounds
  std::lock_guard lock(mutex_);
  if (Entry* e = find_or_check(name, Type::kHistogram)) {
    if (e->histogram->upper_bounds() != h->upper_bounds()) {
      throw std::invalid_argument("metrics: histogram '" + name +
                                  "' is already registered with other bucket bounds");
    }
    return *e->histogram;
  }
  Entry& e = entries_[name];
  e.type = Type::kHistogram;
  e.help = help;
  e.histogram = std::move(h);
  return *e.histogram;
}

std::string Registry::render() const {
  std::string out;
  std::lock_guard lock(mutex_);
  for (const auto& [name, e] : entries_) {
    out += "# HELP " + name + " " + escape_help(e.help) + "\n";
    out += "# TYPE " + name + " " + type_name(e.type) + "\n";
    switch (e.type) {
      case Type::kCounter:
        out += name + " " + format_metric_value(e.counter->value()) + "\n";
        break;
      case Type::kGauge:
        out += name + " " + format_metric_value(e.gauge->value()) + "\n";
        break;
      case Type::kHistogram: {
        const Histogram::Snapshot s = e.histogram->snapshot();
        for (std::size_t i = 0; i < s.cumulative.size(); ++i) {
          const std::string le = i < s.upper_bounds.size() ? format_metric_value(s.upper_bounds[i])
                                                           : std::string("+Inf");
          out += name + "_bucket{le=\"" + le + "\"} " + std::to_string(s.cumulative[i]) + "\n";
        }
        out += name + "_sum " + format_metric_value(s.sum) + "\n";
        out += name + "_count " + std::to_string(s.count) + "\n";
        break;
      }
    }
  }
  return out;
}

}  // namespace arlight::admin
