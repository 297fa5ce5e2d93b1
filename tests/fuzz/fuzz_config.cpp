// Fuzz target: arlightd's own files, which an operator edits by hand: the JSON config, the
// device tokens file and the admin token file. Each must be accepted or refused with an
// InputError naming the file.
#include "arlight/common/error.hpp"
#include "arlight/daemon/daemon.hpp"
#include "fuzz_support.hpp"
#include "tokens.hpp"

using namespace arlight;
namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const fs::path file = fuzz::scratch() / "config";
  fuzz::write_file(file, std::string_view(reinterpret_cast<const char*>(data), size));
  try {
    daemon::DaemonConfig config;
    daemon::load_config_file(file, config);
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  try {
    const daemon::TokenStore tokens = daemon::TokenStore::load(file);
    if (tokens.size() == 0) fuzz::finding("a tokens file was accepted with no tokens");
    tokens.check(tokens.first_device(), "a-token-to-compare");
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  try {
    if (daemon::load_admin_token(file, false).size() < 16)
      fuzz::finding("an admin token shorter than 16 characters was accepted");
  } catch (const InputError& e) {
    fuzz::refused(e);
  }
  return 0;
}

FuzzSeeds arlight_fuzz_seeds() {
  const std::string example =
      fuzz::read_file(fs::path(ARLIGHT_SOURCE_DIR) / "deploy" / "arlightd.example.json");
  const std::string tokens = fuzz::read_file(fs::path(ARLIGHT_SOURCE_DIR) / "deploy" / "tokens.example");
  return {fuzz::bytes_of(example), fuzz::bytes_of(tokens),
          fuzz::bytes_of("# admin token\n0123456789abcdef0123456789abcdef\n"),
          fuzz::bytes_of(R"({"listen": "[::1]:0", "admin": "", "max_sessions": 4})")};
}
