// An H.264 atlas for tests/stream_web/browser_test.py: the same image the JPEG tiles fixture starts
// from, encoded as the server's H.264 atlas is (libx264, Constrained Baseline, Annex B, BT.709
// limited range), one access unit per file, decoded in Chromium by web/atlas_codec.js (WebCodecs).
// Runs only when that script names the output folder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/opt.h>
}

#include "mirage/core/image_metrics.h"

namespace {

using mirage::ImageRGBA8;

ImageRGBA8 smoothAtlas(uint32_t w, uint32_t h) {
  ImageRGBA8 img;
  img.width = w;
  img.height = h;
  img.pixels.assign(size_t(w) * h * 4, 255);
  for (uint32_t y = 0; y < h; ++y)
    for (uint32_t x = 0; x < w; ++x) {
      uint8_t* p = img.at(x, y);
      p[0] = uint8_t(128 + 90 * std::sin(0.05f * float(x)));
      p[1] = uint8_t(128 + 90 * std::cos(0.07f * float(y)));
      p[2] = uint8_t(128 + 60 * std::sin(0.03f * float(x + 2 * y)));
    }
  return img;
}

// RGB -> BT.709 limited-range 4:2:0 (what a decoder's VUI-tagged conversion undoes).
void toYuv(const ImageRGBA8& img, AVFrame* f) {
  for (uint32_t y = 0; y < img.height; ++y)
    for (uint32_t x = 0; x < img.width; ++x) {
      const uint8_t* p = img.at(x, y);
      double r = p[0] / 255.0, g = p[1] / 255.0, b = p[2] / 255.0;
      double luma = 0.2126 * r + 0.7152 * g + 0.0722 * b;
      f->data[0][y * f->linesize[0] + x] = uint8_t(std::lround(16 + 219 * luma));
      if (x % 2 == 0 && y % 2 == 0) {
        f->data[1][(y / 2) * f->linesize[1] + x / 2] = uint8_t(std::lround(128 + 224 * (b - luma) / 1.8556));
        f->data[2][(y / 2) * f->linesize[2] + x / 2] = uint8_t(std::lround(128 + 224 * (r - luma) / 1.5748));
      }
    }
}

TEST(H264Fixture, WritesBrowserFixture) {
  const char* dir = std::getenv("MIRAGE_JPEG_TILES_FIXTURE");
  if (!dir) GTEST_SKIP() << "MIRAGE_JPEG_TILES_FIXTURE not set (tests/stream_web/browser_test.py sets it)";
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (!codec) GTEST_SKIP() << "libavcodec has no libx264";
  const int w = 192, h = 128;
  AVCodecContext* c = avcodec_alloc_context3(codec);
  c->width = w;
  c->height = h;
  c->pix_fmt = AV_PIX_FMT_YUV420P;
  c->time_base = {1, 30};
  c->framerate = {30, 1};
  c->max_b_frames = 0;
  c->colorspace = AVCOL_SPC_BT709;
  c->color_primaries = AVCOL_PRI_BT709;
  c->color_trc = AVCOL_TRC_BT709;
  c->color_range = AVCOL_RANGE_MPEG;
  av_opt_set(c->priv_data, "preset", "ultrafast", 0);
  av_opt_set(c->priv_data, "tune", "zerolatency", 0);
  av_opt_set(c->priv_data, "profile", "baseline", 0);
  av_opt_set(c->priv_data, "crf", "12", 0);
  ASSERT_EQ(avcodec_open2(c, codec, nullptr), 0);
  AVFrame* frame = av_frame_alloc();
  frame->format = c->pix_fmt;
  frame->width = w;
  frame->height = h;
  ASSERT_EQ(av_frame_get_buffer(frame, 0), 0);
  AVPacket* packet = av_packet_alloc();
  ImageRGBA8 image = smoothAtlas(w, h);
  std::vector<std::vector<uint8_t>> units;
  for (int i = 0; i < 2; ++i) {
    ASSERT_EQ(av_frame_make_writable(frame), 0);
    toYuv(image, frame);
    frame->pts = i;
    ASSERT_EQ(avcodec_send_frame(c, frame), 0);
    while (avcodec_receive_packet(c, packet) == 0) {
      units.emplace_back(packet->data, packet->data + packet->size);
      av_packet_unref(packet);
    }
  }
  ASSERT_EQ(avcodec_send_frame(c, nullptr), 0);
  while (avcodec_receive_packet(c, packet) == 0) {
    units.emplace_back(packet->data, packet->data + packet->size);
    av_packet_unref(packet);
  }
  av_packet_free(&packet);
  av_frame_free(&frame);
  avcodec_free_context(&c);
  ASSERT_EQ(units.size(), 2u); // zerolatency: one access unit per frame, none held back
  auto write = [&](const std::string& name, const uint8_t* data, size_t size) {
    std::ofstream out(std::string(dir) + "/" + name, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), std::streamsize(size));
    ASSERT_TRUE(out.good()) << name;
  };
  for (size_t i = 0; i < units.size(); ++i)
    write("atlas" + std::to_string(i) + ".h264", units[i].data(), units[i].size());
  write("h264_source.rgba", image.pixels.data(), image.pixels.size());
}

} // namespace
