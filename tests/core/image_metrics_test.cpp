#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <random>

#include "mirage/core/image_metrics.h"

using namespace mirage;

namespace {

ImageRGBA8 makeImage(uint32_t w, uint32_t h) {
  ImageRGBA8 img;
  img.width = w;
  img.height = h;
  img.pixels.assign(size_t(w) * h * 4, 255);
  return img;
}

// Smooth structured content in 40..215 so moderate offsets and noise never clamp.
ImageRGBA8 pattern(uint32_t w, uint32_t h) {
  ImageRGBA8 img = makeImage(w, h);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = uint8_t(128 + 60 * std::sin(x * 0.21) * std::cos(y * 0.13));
      p[1] = uint8_t(128 + 50 * std::sin((x + y) * 0.07));
      p[2] = uint8_t(100 + 40 * std::cos(x * 0.05 - y * 0.11));
    }
  return img;
}

ImageRGBA8 addNoise(const ImageRGBA8& src, double sigma, uint32_t seed) {
  ImageRGBA8 out = src;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  for (size_t i = 0; i < out.pixels.size(); i += 4)
    for (int c = 0; c < 3; ++c) {
      double v = std::round(out.pixels[i + c] + sigma * n(rng));
      out.pixels[i + c] = uint8_t(std::clamp(v, 0.0, 255.0));
    }
  return out;
}

// Direct 2D evaluation of Wang et al.'s ssim_index: fspecial('gaussian', 11, 1.5) window, 'valid'
// filter2, mean of the SSIM map. Slow on purpose: it shares nothing with the separable version.
double slowSsim(const ImageRGBA8& a, const ImageRGBA8& b) {
  double win[11][11], sum = 0;
  for (int j = 0; j < 11; ++j)
    for (int i = 0; i < 11; ++i)
      sum += win[j][i] = std::exp(-((i - 5) * (i - 5) + (j - 5) * (j - 5)) / (2 * 1.5 * 1.5));
  auto luma = [](const uint8_t* p) { return 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]; };
  const double c1 = std::pow(0.01 * 255, 2), c2 = std::pow(0.03 * 255, 2);
  double total = 0;
  int count = 0;
  for (uint32_t y = 0; y + 11 <= a.height; ++y)
    for (uint32_t x = 0; x + 11 <= a.width; ++x) {
      double mx = 0, my = 0, sxx = 0, syy = 0, sxy = 0;
      for (int j = 0; j < 11; ++j)
        for (int i = 0; i < 11; ++i) {
          double wgt = win[j][i] / sum, u = luma(a.at(x + i, y + j)), v = luma(b.at(x + i, y + j));
          mx += wgt * u;
          my += wgt * v;
          sxx += wgt * u * u;
          syy += wgt * v * v;
          sxy += wgt * u * v;
        }
      double vx = sxx - mx * mx, vy = syy - my * my, cv = sxy - mx * my;
      total += ((2 * mx * my + c1) * (2 * cv + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2));
      ++count;
    }
  return total / count;
}

} // namespace

TEST(ImageMetrics, IdenticalImages) {
  ImageRGBA8 a = pattern(64, 48);
  Result<ImageMetrics> m = compareImages(a, a);
  ASSERT_TRUE(m.ok());
  EXPECT_TRUE(std::isinf(m->psnr) && m->psnr > 0);
  EXPECT_DOUBLE_EQ(m->ssim, 1.0);
  EXPECT_DOUBLE_EQ(m->mae, 0.0);
}

TEST(ImageMetrics, ConstantOffsetGivesAnalyticPsnrAndMae) {
  ImageRGBA8 a = pattern(40, 30), b = a;
  for (size_t i = 0; i < b.pixels.size(); i += 4)
    for (int c = 0; c < 3; ++c) b.pixels[i + c] += 10;
  EXPECT_NEAR(psnr(a, b), 20.0 * std::log10(255.0 / 10.0), 1e-12);
  EXPECT_DOUBLE_EQ(meanAbsoluteError(a, b), 10.0);
}

TEST(ImageMetrics, AlphaIsIgnored) {
  ImageRGBA8 a = pattern(20, 20), b = a;
  for (size_t i = 3; i < b.pixels.size(); i += 4) b.pixels[i] = 0;
  EXPECT_TRUE(std::isinf(psnr(a, b)));
  EXPECT_DOUBLE_EQ(ssim(a, b), 1.0);
}

TEST(ImageMetrics, GaussianNoisePsnrMatchesSigma) {
  ImageRGBA8 flat = makeImage(256, 256);
  for (size_t i = 0; i < flat.pixels.size(); i += 4) flat.pixels[i] = flat.pixels[i + 1] = flat.pixels[i + 2] = 128;
  for (double sigma : {2.0, 5.0, 12.0}) {
    ImageRGBA8 noisy = addNoise(flat, sigma, 7); // 128 ± 5 sigma stays inside 0..255: no clamping
    EXPECT_NEAR(psnr(flat, noisy), 20.0 * std::log10(255.0 / sigma), 0.2) << "sigma " << sigma;
  }
}

TEST(ImageMetrics, SsimOfMeanShiftMatchesLuminanceTerm) {
  // Constant image: variances and covariance are zero, so SSIM reduces to the luminance term.
  ImageRGBA8 a = makeImage(32, 32), b = makeImage(32, 32);
  for (size_t i = 0; i < a.pixels.size(); i += 4)
    for (int c = 0; c < 3; ++c) {
      a.pixels[i + c] = 100;
      b.pixels[i + c] = 140;
    }
  const double c1 = std::pow(0.01 * 255, 2), mx = 100, my = 140;
  EXPECT_NEAR(ssim(a, b), (2 * mx * my + c1) / (mx * mx + my * my + c1), 1e-12);
}

TEST(ImageMetrics, SsimDecreasesMonotonicallyWithNoise) {
  ImageRGBA8 a = pattern(128, 96);
  double previous = 1.0;
  for (double sigma : {1.0, 3.0, 8.0, 20.0, 50.0}) {
    double s = ssim(a, addNoise(a, sigma, 11));
    EXPECT_LT(s, previous) << "sigma " << sigma;
    EXPECT_GT(s, 0.0);
    previous = s;
  }
}

TEST(ImageMetrics, SeparableSsimMatchesDirectReference) {
  ImageRGBA8 a = pattern(37, 29), b = addNoise(a, 15.0, 3);
  EXPECT_NEAR(ssim(a, b), slowSsim(a, b), 1e-6);
  ImageRGBA8 c = addNoise(pattern(11, 11), 30.0, 5); // exactly one window position
  EXPECT_NEAR(ssim(pattern(11, 11), c), slowSsim(pattern(11, 11), c), 1e-6);
}

TEST(ImageMetrics, SizeMismatchIsAnError) {
  Result<ImageMetrics> m = compareImages(makeImage(10, 10), makeImage(10, 11));
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("10x10 vs 10x11"), std::string::npos);
  EXPECT_TRUE(std::isnan(ssim(makeImage(10, 10), makeImage(11, 10))));
  EXPECT_FALSE(compareImages(ImageRGBA8{}, ImageRGBA8{}).ok());
}

TEST(ImageMetrics, TinyImagesUseGlobalStatistics) {
  ImageRGBA8 a = pattern(5, 4);
  EXPECT_DOUBLE_EQ(ssim(a, a), 1.0);
}

TEST(ImageMetrics, FullHdIsFast) {
  ImageRGBA8 a = pattern(1920, 1080), b = addNoise(a, 5.0, 1);
  auto start = std::chrono::steady_clock::now();
  Result<ImageMetrics> m = compareImages(a, b);
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  ASSERT_TRUE(m.ok());
  EXPECT_LT(seconds, 1.0);
  RecordProperty("compare_1080p_ms", int(seconds * 1000));
}
