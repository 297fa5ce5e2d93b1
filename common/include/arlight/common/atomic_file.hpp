// Files that are either the old version or the new one, never half written.
#pragma once

#include <filesystem>
#include <string_view>

namespace arlight {

// A unique temporary name next to `path` (same folder, so renaming it over `path` is atomic).
std::filesystem::path temp_sibling(const std::filesystem::path& path);

// Writes `bytes` to a temporary sibling, fsyncs it, renames it over `path` and fsyncs the
// folder; on failure the
// temporary is removed, `path` is untouched and std::runtime_error names the path.
void write_file_atomically(const std::filesystem::path& path, std::string_view bytes);

}  // namespace arlight
