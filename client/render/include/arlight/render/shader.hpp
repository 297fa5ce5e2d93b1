// GLSL ES 3.00 programs read from a shader folder at run time. Before compiling, the loader puts
// `#define NAME VALUE` lines after the `#version 300 es` line and replaces each line
// `#include "file"` with that file from the same folder (one level); `#line` directives keep
// the GL info log's line numbers pointing at the right file. Failures throw GlError with the
// file names and the info log.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace arlight::render {

// The folder the library was built with (ARLIGHT_SHADER_DIR, the repository's shaders/).
std::filesystem::path default_shader_dir();

class Program {
 public:
  Program() = default;
  // Compiles and links dir/vert + dir/frag with the given defines.
  Program(const std::filesystem::path& dir, const std::string& vert, const std::string& frag,
          const std::vector<std::pair<std::string, std::string>>& defines = {});
  Program(Program&& o) noexcept : id_(std::exchange(o.id_, 0)), name_(std::move(o.name_)) {}
  Program& operator=(Program&& o) noexcept;
  Program(const Program&) = delete;
  Program& operator=(const Program&) = delete;
  ~Program();

  unsigned id() const { return id_; }
  const std::string& name() const { return name_; }  // "vert+frag"
  // Location of a uniform, -1 when the linker removed it (callers may ignore that).
  int uniform(const char* name) const;

 private:
  unsigned id_ = 0;
  std::string name_;
};

}  // namespace arlight::render
