// mirage compare: image metrics between two renders (the check every invisible-optimisation claim uses).
#include <cmath>
#include <memory>
#include <string>

#include <fmt/core.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/core/image_metrics.h"
#include "mirage/io/image_io.h"

namespace mirage::cli {

namespace {

struct CompareArgs {
  std::string a, b;
  bool json = false;
};

// JSON numbers cannot be infinite: identical images report "psnr": null.
std::string jsonNumber(double v, int decimals) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : "null";
}

void runCompare(const CompareArgs& args) {
  Result<ImageRGBA8> a = io::readPng(args.a);
  if (!a) return fail(a.error());
  Result<ImageRGBA8> b = io::readPng(args.b);
  if (!b) return fail(b.error());
  Result<ImageMetrics> m = compareImages(*a, *b);
  if (!m) return fail(args.a + " vs " + args.b + ": " + m.error().message);
  if (args.json) {
    fmt::print("{{\"psnr\":{},\"ssim\":{},\"mae\":{}}}\n", jsonNumber(m->psnr, 4), jsonNumber(m->ssim, 6),
               jsonNumber(m->mae, 4));
  } else {
    std::string psnr = std::isinf(m->psnr) ? "inf" : fmt::format("{:.2f}", m->psnr);
    fmt::print("psnr {} dB  ssim {:.4f}  mae {:.3f}\n", psnr, m->ssim, m->mae);
  }
}

} // namespace

void addCompareCommand(CLI::App& app) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = app.add_subcommand("compare", "PSNR (RGB, dB), SSIM (luma, Wang et al. 2004) and MAE of two images");
  cmd->add_option("a", args->a, "First image (PNG, JPG, ...)")->required();
  cmd->add_option("b", args->b, "Second image, same size")->required();
  cmd->add_flag("--json", args->json, "Print {\"psnr\":..,\"ssim\":..,\"mae\":..}; psnr is null for identical images");
  cmd->callback([args] { runCompare(*args); });
}

} // namespace mirage::cli
