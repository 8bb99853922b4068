#pragma once
// Image comparison: how every LOD, culling and streaming feature proves it is invisible.
#include "mirage/core/image.h"
#include "mirage/core/result.h"

namespace mirage {

struct ImageMetrics {
  double psnr = 0.0; // dB over RGB, 8-bit peak 255; +infinity for identical images
  double ssim = 0.0; // mean SSIM (Wang et al. 2004) on luminance, 11x11 Gaussian window, sigma 1.5
  double mae = 0.0;  // mean absolute error over RGB channels, in 0..255 units
};

// Images must have equal sizes; otherwise an Error naming both sizes.
Result<ImageMetrics> compareImages(const ImageRGBA8& a, const ImageRGBA8& b);
double psnr(const ImageRGBA8& a, const ImageRGBA8& b);
double ssim(const ImageRGBA8& a, const ImageRGBA8& b);
double meanAbsoluteError(const ImageRGBA8& a, const ImageRGBA8& b);

} // namespace mirage
