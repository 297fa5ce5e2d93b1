// arlight-maps preview: an HDR environment map (or any HDR image) as a PNG for people to look
// at, with a global or a local tone-mapping operator (tutorial §9).
#include <cstdio>
#include <optional>
#include <string>

#include "arlight/common/hdr_io.hpp"
#include "arlight/preview/tone_preview.hpp"
#include "commands.hpp"

namespace arlight::maps {

Runner add_preview_command(CLI::App& app) {
  struct Options {
    std::string input, out, tone = "global";
    std::optional<double> exposure;
  };
  auto o = std::make_shared<Options>();
  CLI::App* sub = app.add_subcommand(
      "preview", "an HDR image as an 8-bit sRGB PNG, tone mapped globally or locally");
  sub->add_option("input", o->input, "HDR image (EXR, HDR, PFM, ...)")->required();
  sub->add_option("--out", o->out, "the PNG to write")->required();
  sub->add_option("--tone", o->tone,
                  "global (Reinhard's x/(1+x)), or a local operator: drago, reinhard "
                  "(Reinhard & Devlin) or mantiuk")
      ->capture_default_str();
  sub->add_option("--exposure", o->exposure,
                  "exposure in stops (default: the log-average luminance to 18 % grey)");
  return [o] {
    const PreviewTone tone = parse_preview_tone(o->tone);
    const LoadedImage image = load_image(o->input);
    write_tone_preview(o->out, image.image.view(), {o->exposure, tone});
    std::printf("arlight-maps: wrote %s (%s tone mapping)\n", o->out.c_str(),
                preview_tone_name(tone));
    return 0;
  };
}

}  // namespace arlight::maps
