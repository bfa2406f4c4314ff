// `penumbra compare A B [--diff D.png] [--scale S]`: RMSE and PSNR between two images, and a false-colour
// difference image. `penumbra montage OUT IN...`: images side by side.
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

void add_montage_command(CLI::App& app) {
  struct Options {
    std::string output;
    std::vector<std::string> inputs;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("montage", "Put images side by side (for comparisons)");
  cmd->add_option("output", o->output, "Output image (.png or .pfm)")->required();
  cmd->add_option("inputs", o->inputs, "Images, left to right")->required();
  cmd->callback([o] {
    std::vector<Image> images;
    for (const auto& p : o->inputs) images.push_back(read_image(p));
    std::vector<const Image*> ptrs;
    for (const auto& im : images) ptrs.push_back(&im);
    write_image(o->output, montage(ptrs));
  });
}

}  // namespace penumbra::cli
