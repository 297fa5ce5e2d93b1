// open_source: the client's --source spec to a FrameSource, over the built-in schemes (v4l2:,
// replay:) and those a program registered (register_source_scheme: the laboratory's sim:).
#include <mutex>
#include <stdexcept>
#include <string_view>
#include <utility>
#include <vector>

#include "arlight/common/error.hpp"
#include "arlight/source/source.hpp"

namespace arlight::source {

namespace {

struct Scheme {
  std::string name;  // without the ':'
  SourceFactory open;
  std::string usage;  // as the error lists it
};

// The schemes open_source knows, in the order its error lists them: the built-ins first, then
// the registered ones in their order of registration.
struct Schemes {
  std::mutex mutex;
  std::vector<Scheme> list{
      {"v4l2",
       [](const std::string& device, const SourceOptions& o) -> std::unique_ptr<FrameSource> {
         return std::make_unique<V4l2Source>(device, o);
       },
       "v4l2:/dev/videoN (a webcam)"},
      {"replay",
       [](const std::string& folder, const SourceOptions& o) -> std::unique_ptr<FrameSource> {
         return std::make_unique<ReplaySource>(folder, o);
       },
       "replay:REC_FOLDER (a recording)"}};
};

Schemes& schemes() {
  static Schemes s;
  return s;
}

}  // namespace

void register_source_scheme(const std::string& scheme, SourceFactory factory, std::string usage) {
  if (scheme.empty() || scheme.find(':') != std::string::npos)
    throw std::invalid_argument("register_source_scheme: bad scheme '" + scheme + "'");
  Schemes& s = schemes();
  const std::lock_guard lock(s.mutex);
  for (Scheme& known : s.list)
    if (known.name == scheme) {
      known.open = std::move(factory), known.usage = std::move(usage);
      return;
    }
  s.list.push_back({scheme, std::move(factory), std::move(usage)});
}

std::unique_ptr<FrameSource> open_source(const std::string& spec, const SourceOptions& options) {
  const std::string_view s(spec);
  SourceFactory open;
  std::string rest, usages;
  {
    Schemes& known = schemes();
    const std::lock_guard lock(known.mutex);
    for (const Scheme& scheme : known.list)
      if (s.size() > scheme.name.size() + 1 && s.starts_with(scheme.name) &&
          s[scheme.name.size()] == ':') {
        open = scheme.open, rest = spec.substr(scheme.name.size() + 1);
        break;
      }
    if (!open)
      for (std::size_t i = 0; i < known.list.size(); ++i)
        usages += (i == 0 ? "" : i + 1 == known.list.size() ? " or " : ", ") + known.list[i].usage;
  }
  if (open) return open(rest, options);  // outside the lock: opening a device takes time
  throw InputError("source '" + spec + "': expected " + usages);
}

}  // namespace arlight::source
