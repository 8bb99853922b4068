#include "mirage/core/image_metrics.h"

#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace mirage {

namespace {

bool sameSize(const ImageRGBA8& a, const ImageRGBA8& b) { return a.width == b.width && a.height == b.height; }

bool wellFormed(const ImageRGBA8& img) { return img.pixels.size() == size_t(img.width) * img.height * 4; }

std::string sizeText(const ImageRGBA8& img) { return std::to_string(img.width) + "x" + std::to_string(img.height); }

// Wang et al. 2004 constants for 8-bit images.
constexpr double kL = 255.0;
constexpr double kC1 = (0.01 * kL) * (0.01 * kL);
constexpr double kC2 = (0.03 * kL) * (0.03 * kL);
constexpr int kWindow = 11;
constexpr int kRadius = kWindow / 2;

// 1D Gaussian taps, sigma 1.5, normalised. MATLAB's fspecial('gaussian', 11, 1.5) is the outer
// product of these taps (exp separates and the normalisation factorises), so two 1D passes give
// exactly the reference 2D window.
std::array<double, kWindow> gaussianTaps() {
  std::array<double, kWindow> w{};
  double sum = 0.0;
  for (int i = 0; i < kWindow; ++i) {
    double x = i - kRadius;
    w[i] = std::exp(-(x * x) / (2.0 * 1.5 * 1.5));
    sum += w[i];
  }
  for (double& v : w) v /= sum;
  return w;
}

// ITU-R BT.601 luma on 0..255 values, as in the reference implementation's rgb2gray step.
std::vector<double> luminance(const ImageRGBA8& img) {
  std::vector<double> y(size_t(img.width) * img.height);
  for (size_t i = 0; i < y.size(); ++i) {
    const uint8_t* p = &img.pixels[i * 4];
    y[i] = 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2];
  }
  return y;
}

double ssimTerm(double mx, double my, double sxx, double syy, double sxy) {
  double vx = sxx - mx * mx, vy = syy - my * my, cxy = sxy - mx * my;
  return ((2.0 * mx * my + kC1) * (2.0 * cxy + kC2)) / ((mx * mx + my * my + kC1) * (vx + vy + kC2));
}

// Images smaller than the window have no 'valid' position; rather than failing, use the statistics
// of the whole image with uniform weights (the window degenerates to the image).
double globalSsim(const std::vector<double>& x, const std::vector<double>& y) {
  double n = double(x.size()), mx = 0, my = 0, sxx = 0, syy = 0, sxy = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    mx += x[i];
    my += y[i];
    sxx += x[i] * x[i];
    syy += y[i] * y[i];
    sxy += x[i] * y[i];
  }
  return ssimTerm(mx / n, my / n, sxx / n, syy / n, sxy / n);
}

} // namespace

double psnr(const ImageRGBA8& a, const ImageRGBA8& b) {
  if (!sameSize(a, b) || !wellFormed(a) || !wellFormed(b) || a.pixels.empty())
    return std::numeric_limits<double>::quiet_NaN();
  uint64_t sum = 0; // exact: squared 8-bit differences fit easily in 64 bits
  for (size_t i = 0; i < a.pixels.size(); i += 4) {
    for (int c = 0; c < 3; ++c) {
      int d = int(a.pixels[i + c]) - int(b.pixels[i + c]);
      sum += uint64_t(d * d);
    }
  }
  if (sum == 0) return std::numeric_limits<double>::infinity();
  double mse = double(sum) / (double(a.pixels.size() / 4) * 3.0);
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

double meanAbsoluteError(const ImageRGBA8& a, const ImageRGBA8& b) {
  if (!sameSize(a, b) || !wellFormed(a) || !wellFormed(b) || a.pixels.empty())
    return std::numeric_limits<double>::quiet_NaN();
  uint64_t sum = 0;
  for (size_t i = 0; i < a.pixels.size(); i += 4)
    for (int c = 0; c < 3; ++c) sum += uint64_t(std::abs(int(a.pixels[i + c]) - int(b.pixels[i + c])));
  return double(sum) / (double(a.pixels.size() / 4) * 3.0);
}

double ssim(const ImageRGBA8& a, const ImageRGBA8& b) {
  if (!sameSize(a, b) || !wellFormed(a) || !wellFormed(b) || a.pixels.empty())
    return std::numeric_limits<double>::quiet_NaN();
  const std::vector<double> x = luminance(a), y = luminance(b);
  const int w = int(a.width), h = int(a.height);
  if (w < kWindow || h < kWindow) return globalSsim(x, y);

  const std::array<double, kWindow> taps = gaussianTaps();
  const int ow = w - 2 * kRadius, oh = h - 2 * kRadius;
  // Horizontally filtered rows of the five moment images (x, y, x², y², xy) live in a ring of
  // kWindow rows, so memory stays O(width) and each output row needs one vertical 11-tap pass.
  constexpr int kMoments = 5;
  std::vector<double> ring(size_t(kWindow) * kMoments * ow);
  auto slot = [&](int row, int moment) { return &ring[(size_t(row % kWindow) * kMoments + moment) * ow]; };

  double total = 0.0;
  for (int row = 0; row < h; ++row) {
    const double* xr = &x[size_t(row) * w];
    const double* yr = &y[size_t(row) * w];
    double* hx = slot(row, 0);
    double* hy = slot(row, 1);
    double* hxx = slot(row, 2);
    double* hyy = slot(row, 3);
    double* hxy = slot(row, 4);
    for (int i = 0; i < ow; ++i) {
      double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
      for (int k = 0; k < kWindow; ++k) {
        double t = taps[k], xv = xr[i + k], yv = yr[i + k];
        sx += t * xv;
        sy += t * yv;
        sxx += t * xv * xv;
        syy += t * yv * yv;
        sxy += t * xv * yv;
      }
      hx[i] = sx;
      hy[i] = sy;
      hxx[i] = sxx;
      hyy[i] = syy;
      hxy[i] = sxy;
    }
    if (row < kWindow - 1) continue;

    const int top = row - (kWindow - 1); // first input row of this output row's window
    const double* rows[kWindow][kMoments];
    for (int k = 0; k < kWindow; ++k)
      for (int q = 0; q < kMoments; ++q) rows[k][q] = slot(top + k, q);
    double rowSum = 0.0;
    for (int i = 0; i < ow; ++i) {
      double m[kMoments] = {0, 0, 0, 0, 0};
      for (int k = 0; k < kWindow; ++k) {
        double t = taps[k];
        for (int q = 0; q < kMoments; ++q) m[q] += t * rows[k][q][i];
      }
      rowSum += ssimTerm(m[0], m[1], m[2], m[3], m[4]);
    }
    total += rowSum;
  }
  return total / (double(ow) * double(oh));
}

Result<ImageMetrics> compareImages(const ImageRGBA8& a, const ImageRGBA8& b) {
  if (!sameSize(a, b)) return Error{"image sizes differ: " + sizeText(a) + " vs " + sizeText(b)};
  if (!wellFormed(a) || !wellFormed(b)) return Error{"image pixel data does not match its size " + sizeText(a)};
  if (a.pixels.empty()) return Error{"images are empty (0 pixels)"};
  return ImageMetrics{psnr(a, b), ssim(a, b), meanAbsoluteError(a, b)};
}

} // namespace mirage
