#include "arlight/render/shader.hpp"

#include <fstream>
#include <sstream>
#include <vector>

#include "gl.hpp"

namespace arlight::render {

namespace {

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw GlError("cannot read shader '" + path.string() + "'");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The source handed to GL, and the file behind each GLSL source-string number used in #line.
struct Assembled {
  std::string text;
  std::vector<std::string> files;
};

Assembled assemble(const std::filesystem::path& dir, const std::string& file,
                   const std::vector<std::pair<std::string, std::string>>& defines) {
  Assembled a;
  a.files.push_back(file);
  std::istringstream in(read_text(dir / file));
  std::string line;
  int number = 0;
  bool version_seen = false;
  while (std::getline(in, line)) {
    ++number;
    if (!version_seen && line.rfind("#version", 0) == 0) {
      if (line.find("300 es") == std::string::npos)
        throw GlError(file + ": must start with '#version 300 es' (GLSL ES 3.00), got '" + line +
                      "'");
      version_seen = true;
      a.text += line + "\n";
      for (const auto& [name, value] : defines) a.text += "#define " + name + " " + value + "\n";
      a.text += "#line " + std::to_string(number + 1) + " 0\n";
      continue;
    }
    if (line.rfind("#include", 0) == 0) {
      const auto q0 = line.find('"'), q1 = line.rfind('"');
      if (q0 == std::string::npos || q1 <= q0)
        throw GlError(file + ":" + std::to_string(number) + ": malformed #include");
      const std::string inc = line.substr(q0 + 1, q1 - q0 - 1);
      const int id = int(a.files.size());
      a.files.push_back(inc);
      a.text += "#line 1 " + std::to_string(id) + "\n" + read_text(dir / inc) + "\n";
      a.text += "#line " + std::to_string(number + 1) + " 0\n";
      continue;
    }
    a.text += line + "\n";
  }
  if (!version_seen) throw GlError(file + ": missing '#version 300 es'");
  return a;
}

GLuint compile(GLenum type, const std::filesystem::path& dir, const std::string& file,
               const std::vector<std::pair<std::string, std::string>>& defines) {
  const Assembled a = assemble(dir, file, defines);
  const GLuint s = glCreateShader(type);
  const char* src = a.text.c_str();
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (ok) return s;
  GLint len = 0;
  glGetShaderiv(s, GL_INFO_LOG_LENGTH, &len);
  std::string log(std::size_t(std::max(len, 1)), '\0');
  glGetShaderInfoLog(s, len, nullptr, log.data());
  glDeleteShader(s);
  std::string legend;
  for (std::size_t i = 0; i < a.files.size(); ++i)
    legend += (i ? ", " : "") + std::to_string(i) + " = " + a.files[i];
  throw GlError("compiling shader '" + (dir / file).string() + "' failed (source numbers: " +
                legend + "):\n" + log.c_str());
}

}  // namespace

std::filesystem::path default_shader_dir() { return ARLIGHT_SHADER_DIR; }

Program::Program(const std::filesystem::path& dir, const std::string& vert,
                 const std::string& frag,
                 const std::vector<std::pair<std::string, std::string>>& defines)
    : name_(vert + "+" + frag) {
  const GLuint vs = compile(GL_VERTEX_SHADER, dir, vert, defines);
  GLuint fs = 0;
  try {
    fs = compile(GL_FRAGMENT_SHADER, dir, frag, defines);
  } catch (...) {
    glDeleteShader(vs);
    throw;
  }
  id_ = glCreateProgram();
  glAttachShader(id_, vs);
  glAttachShader(id_, fs);
  glLinkProgram(id_);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(id_, GL_LINK_STATUS, &ok);
  if (ok) return;
  GLint len = 0;
  glGetProgramiv(id_, GL_INFO_LOG_LENGTH, &len);
  std::string log(std::size_t(std::max(len, 1)), '\0');
  glGetProgramInfoLog(id_, len, nullptr, log.data());
  glDeleteProgram(id_);
  id_ = 0;
  throw GlError("linking program " + (dir / vert).string() + " + " + frag + " failed:\n" +
                log.c_str());
}

Program& Program::operator=(Program&& o) noexcept {
  std::swap(id_, o.id_);
  std::swap(name_, o.name_);
  return *this;
}

Program::~Program() {
  if (id_) glDeleteProgram(id_);
}

int Program::uniform(const char* name) const { return glGetUniformLocation(id_, name); }

}  // namespace arlight::render
