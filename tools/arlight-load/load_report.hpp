// arlight-load's report: the sessions' figures together (latency percentiles, map-set intervals,
// outages), as JSON, a per-frame trace and the summary lines.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "load_session.hpp"

namespace arlight::load {

// The p-th percentile (0-100, linear between ranks) of v; 0 when empty.
double percentile(std::vector<double> v, double p);

// The run's JSON report (arlight-load --json; tests and bench scripts read its fields).
nlohmann::json report_json(const std::vector<SessionReport>& reports, const std::string& phases,
                           double rate, double duration);
// Every frame as CSV: session,sequence,sent_ms,latency_ms (empty when no update reflects it).
std::string trace_csv(const std::vector<SessionReport>& reports);
// The summary on stdout (errors on stderr).
void print_summary(const nlohmann::json& j);

}  // namespace arlight::load
