// `penumbra compare A B [--diff D.png] [--scale S]`: RMSE and PSNR between two images, and a false-colour
// difference image.
#include <cstdio>

#include "commands.h"
#include "penumbra/core/image_io.h"

namespace penumbra::cli {

void add_compare_command(CLI::App& app) {
  struct Options {
    std::string a, b, diff;
    float scale = 0.1f;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("compare", "RMSE and PSNR between two images (.png or .pfm)");
  cmd->add_option("a", o->a, "First image")->required();
  cmd->add_option("b", o->b, "Second image (the reference)")->required();
  cmd->add_option("--diff", o->diff, "Write a false-colour difference image (black: equal, red: >= scale)");
  cmd->add_option("--scale", o->scale, "Difference shown as full red")->check(CLI::Range(1e-6, 1.0));
  cmd->callback([o] {
    const Image a = read_image(o->a);
    const Image b = read_image(o->b);
    const ImageDifference d = compare_images(a, b);
    std::printf("rmse %.6f\npsnr %.2f dB\nmax_abs %.6f\n", d.rmse, d.psnr, d.max_abs);
    if (!o->diff.empty()) write_image(o->diff, difference_image(a, b, o->scale));
  });
}

}  // namespace penumbra::cli
