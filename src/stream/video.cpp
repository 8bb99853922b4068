// H.264 atlas codec through libavcodec and libswscale (docs/stream.md, "Codecs").
#include "mirage/stream/video.h"

#include <algorithm>
#include <cstring>

extern "C" {
#include <libavcodec/avcodec.h>
#include <libavutil/error.h>
#include <libavutil/imgutils.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libswscale/swscale.h>
}

namespace mirage::stream {
namespace {

// One owner per libav object.
struct CodecContextDeleter {
  void operator()(AVCodecContext* context) const { avcodec_free_context(&context); }
};
struct FrameDeleter {
  void operator()(AVFrame* frame) const { av_frame_free(&frame); }
};
struct PacketDeleter {
  void operator()(AVPacket* packet) const { av_packet_free(&packet); }
};
struct SwsDeleter {
  void operator()(SwsContext* context) const { sws_freeContext(context); }
};
using CodecContextPtr = std::unique_ptr<AVCodecContext, CodecContextDeleter>;
using FramePtr = std::unique_ptr<AVFrame, FrameDeleter>;
using PacketPtr = std::unique_ptr<AVPacket, PacketDeleter>;
using SwsPtr = std::unique_ptr<SwsContext, SwsDeleter>;

constexpr uint32_t kMaxVideoSide = 16384;
// Chroma stays inside 2 x 2 texel quads: the encoder averages each quad (area filter), the decoder
// repeats its sample (point). Blocks are >= 2 x 2 and aligned to their size, so no quad straddles
// two blocks and no patch takes colour from its neighbour (a bilinear chroma filter bleeds across
// block borders: 28 dB instead of 43 dB on the tests' synthetic atlas).
constexpr int kSwsToYuvFlags = SWS_AREA | SWS_ACCURATE_RND;
constexpr int kSwsToRgbaFlags = SWS_POINT | SWS_ACCURATE_RND | SWS_FULL_CHR_H_INT;

std::string avError(int code) {
  char text[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, text, sizeof(text));
  return text;
}

Error encoderError(const std::string& problem) { return Error{"video encoder: " + problem}; }
Error decoderError(const std::string& problem) { return Error{"video decoder: " + problem}; }

// x264's banner and per-stream statistics arrive at AV_LOG_INFO: keep them out of server logs.
void quietLibav() {
  if (av_log_get_level() > AV_LOG_ERROR) av_log_set_level(AV_LOG_ERROR);
}

// Full-range BT.709 both ways, so the YUV round trip loses only what 4:2:0 and the codec lose.
void setFullRange709(SwsContext* sws) {
  const int* coefficients = sws_getCoefficients(SWS_CS_ITU709);
  sws_setColorspaceDetails(sws, coefficients, 1, coefficients, 1, 0, 1 << 16, 1 << 16);
}

// RGBA8 -> YUV420P as the encoder takes it (kSwsToYuvFlags, full-range BT.709); null if libswscale
// lacks it.
SwsPtr rgbaToYuvContext(uint32_t width, uint32_t height) {
  SwsPtr sws(sws_getContext(int(width), int(height), AV_PIX_FMT_RGBA, int(width), int(height), AV_PIX_FMT_YUV420P,
                            kSwsToYuvFlags, nullptr, nullptr, nullptr));
  if (sws) setFullRange709(sws.get());
  return sws;
}

std::string sizeText(uint32_t width, uint32_t height) { return std::to_string(width) + "x" + std::to_string(height); }

// I420: the three planes back to back, rows without padding.
size_t i420Bytes(uint32_t width, uint32_t height) { return size_t(width) * height * 3 / 2; }

// ABR at `kbps`, capped by a VBV of config.vbvFrames frames of it: a frame's size stays near kbps / fps.
void setRates(AVCodecContext* c, const VideoConfig& config, uint32_t kbps) {
  int64_t bitrate = int64_t(kbps) * 1000;
  c->bit_rate = bitrate;
  c->rc_max_rate = bitrate;
  c->rc_buffer_size = int(bitrate * config.vbvFrames / config.fps);
}

} // namespace

Result<std::vector<uint8_t>> rgbaToI420(std::span<const uint8_t> rgba, uint32_t width, uint32_t height) {
  if (width == 0 || height == 0 || width % 2 || height % 2 || width > kMaxVideoSide || height > kMaxVideoSide)
    return Error{"rgbaToI420: size " + sizeText(width, height) + " must be even and in [2, 16384]"};
  if (rgba.size() != size_t(width) * height * 4)
    return Error{"rgbaToI420: image of " + std::to_string(rgba.size()) + " bytes, expected " + sizeText(width, height) +
                 " RGBA8"};
  SwsPtr sws = rgbaToYuvContext(width, height);
  if (!sws) return Error{"rgbaToI420: libswscale has no RGBA -> YUV420P conversion"};
  std::vector<uint8_t> out(i420Bytes(width, height));
  const size_t lumaBytes = size_t(width) * height;
  uint8_t* planes[3] = {out.data(), out.data() + lumaBytes, out.data() + lumaBytes + lumaBytes / 4};
  const int strides[3] = {int(width), int(width / 2), int(width / 2)};
  const uint8_t* source[1] = {rgba.data()};
  const int sourceStride[1] = {int(width * 4)};
  sws_scale(sws.get(), source, sourceStride, 0, int(height), planes, strides);
  return out;
}

struct VideoEncoder::State {
  VideoConfig config;
  CodecContextPtr context;
  FramePtr frame;
  PacketPtr packet;
  SwsPtr toYuv;
  int64_t pts = 0;
};

VideoEncoder::VideoEncoder(std::unique_ptr<State> state) : state_(std::move(state)) {}
VideoEncoder::VideoEncoder(VideoEncoder&&) noexcept = default;
VideoEncoder& VideoEncoder::operator=(VideoEncoder&&) noexcept = default;
VideoEncoder::~VideoEncoder() = default;
const VideoConfig& VideoEncoder::config() const { return state_->config; }

void VideoEncoder::setBitrate(uint32_t kbps) {
  State& s = *state_;
  kbps = std::max(kbps, 1u);
  if (kbps == s.config.bitrateKbps) return;
  s.config.bitrateKbps = kbps;
  setRates(s.context.get(), s.config, kbps);
}

Result<VideoEncoder> VideoEncoder::create(const VideoConfig& config) {
  if (config.width == 0 || config.height == 0 || config.width % 2 || config.height % 2 ||
      config.width > kMaxVideoSide || config.height > kMaxVideoSide) {
    return encoderError("size " + std::to_string(config.width) + "x" + std::to_string(config.height) +
                        " must be even and in [2, 16384]");
  }
  if (config.fps == 0 || config.bitrateKbps == 0 || config.vbvFrames == 0) {
    return encoderError("fps, bitrate and VBV frames must be > 0");
  }
  quietLibav();
  const AVCodec* codec = avcodec_find_encoder_by_name("libx264");
  if (!codec) return encoderError("libavcodec has no libx264 encoder");

  auto state = std::make_unique<State>();
  state->config = config;
  state->context.reset(avcodec_alloc_context3(codec));
  state->frame.reset(av_frame_alloc());
  state->packet.reset(av_packet_alloc());
  if (!state->context || !state->frame || !state->packet) return encoderError("out of memory");

  AVCodecContext* c = state->context.get();
  c->width = int(config.width);
  c->height = int(config.height);
  c->time_base = AVRational{1, int(config.fps)};
  c->framerate = AVRational{int(config.fps), 1};
  c->pix_fmt = AV_PIX_FMT_YUV420P;
  c->color_range = AVCOL_RANGE_JPEG;
  c->colorspace = AVCOL_SPC_BT709;
  c->color_primaries = AVCOL_PRI_BT709;
  c->color_trc = AVCOL_TRC_BT709;
  setRates(c, config, config.bitrateKbps);
  c->max_b_frames = 0;
  c->gop_size = int(config.keyframeInterval ? config.keyframeInterval : config.fps * 4);
  // zerolatency makes them slice threads (libavcodec's libx264 leaves x264's thread type alone
  // unless thread_type is set): every frame is cut into one slice per thread, no frame delay.
  c->thread_count = int(config.threads);
  av_opt_set(c->priv_data, "preset", config.preset.c_str(), 0);
  av_opt_set(c->priv_data, "tune", "zerolatency", 0);
  av_opt_set_int(c->priv_data, "forced-idr", 1, 0); // a forced keyframe is an IDR: a joining client can start there
  if (config.intraRefresh) av_opt_set_int(c->priv_data, "intra-refresh", 1, 0);
  if (int status = avcodec_open2(c, codec, nullptr); status < 0) {
    return encoderError("libx264 refused the settings (preset " + config.preset + "): " + avError(status));
  }

  AVFrame* frame = state->frame.get();
  frame->format = AV_PIX_FMT_YUV420P;
  frame->width = c->width;
  frame->height = c->height;
  frame->color_range = AVCOL_RANGE_JPEG;
  frame->colorspace = AVCOL_SPC_BT709;
  if (int status = av_frame_get_buffer(frame, 0); status < 0) return encoderError(avError(status));

  state->toYuv = rgbaToYuvContext(config.width, config.height);
  if (!state->toYuv) return encoderError("libswscale has no RGBA -> YUV420P conversion");
  return VideoEncoder(std::move(state));
}

Result<VideoPacket> VideoEncoder::encode(std::span<const uint8_t> rgba, bool forceKeyframe) {
  State& s = *state_;
  if (rgba.size() != size_t(s.config.width) * s.config.height * 4) {
    return encoderError("image of " + std::to_string(rgba.size()) + " bytes, expected " +
                        sizeText(s.config.width, s.config.height) + " RGBA8");
  }
  AVFrame* frame = s.frame.get();
  if (int status = av_frame_make_writable(frame); status < 0) return encoderError(avError(status));
  const uint8_t* source[1] = {rgba.data()};
  const int sourceStride[1] = {int(s.config.width * 4)};
  sws_scale(s.toYuv.get(), source, sourceStride, 0, int(s.config.height), frame->data, frame->linesize);
  return encodeFrame(forceKeyframe);
}

Result<VideoPacket> VideoEncoder::encodeI420(std::span<const uint8_t> i420, bool forceKeyframe) {
  State& s = *state_;
  const uint32_t w = s.config.width, h = s.config.height;
  if (i420.size() != i420Bytes(w, h)) {
    return encoderError("image of " + std::to_string(i420.size()) + " bytes, expected " + sizeText(w, h) + " I420");
  }
  AVFrame* frame = s.frame.get();
  if (int status = av_frame_make_writable(frame); status < 0) return encoderError(avError(status));
  const size_t lumaBytes = size_t(w) * h;
  const uint8_t* planes[4] = {i420.data(), i420.data() + lumaBytes, i420.data() + lumaBytes + lumaBytes / 4, nullptr};
  const int strides[4] = {int(w), int(w / 2), int(w / 2), 0};
  av_image_copy(frame->data, frame->linesize, planes, strides, AV_PIX_FMT_YUV420P, int(w), int(h));
  return encodeFrame(forceKeyframe);
}

Result<VideoPacket> VideoEncoder::encodeFrame(bool forceKeyframe) {
  State& s = *state_;
  AVFrame* frame = s.frame.get();
  frame->pts = s.pts++;
  frame->pict_type = forceKeyframe ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;

  if (int status = avcodec_send_frame(s.context.get(), frame); status < 0) return encoderError(avError(status));
  VideoPacket out;
  for (;;) {
    int status = avcodec_receive_packet(s.context.get(), s.packet.get());
    if (status == AVERROR(EAGAIN) || status == AVERROR_EOF) break;
    if (status < 0) return encoderError(avError(status));
    out.data.insert(out.data.end(), s.packet->data, s.packet->data + s.packet->size);
    out.keyframe = out.keyframe || (s.packet->flags & AV_PKT_FLAG_KEY);
    av_packet_unref(s.packet.get());
  }
  return out;
}

struct VideoDecoder::State {
  CodecContextPtr context;
  FramePtr frame;
  PacketPtr packet;
  SwsPtr toRgba;
  std::vector<uint8_t> image;
  uint32_t width = 0, height = 0;
};

VideoDecoder::VideoDecoder(std::unique_ptr<State> state) : state_(std::move(state)) {}
VideoDecoder::VideoDecoder(VideoDecoder&&) noexcept = default;
VideoDecoder& VideoDecoder::operator=(VideoDecoder&&) noexcept = default;
VideoDecoder::~VideoDecoder() = default;
const std::vector<uint8_t>& VideoDecoder::image() const { return state_->image; }
uint32_t VideoDecoder::width() const { return state_->width; }
uint32_t VideoDecoder::height() const { return state_->height; }

Result<VideoDecoder> VideoDecoder::create() {
  quietLibav();
  const AVCodec* codec = avcodec_find_decoder(AV_CODEC_ID_H264);
  if (!codec) return decoderError("libavcodec has no h264 decoder");
  auto state = std::make_unique<State>();
  state->context.reset(avcodec_alloc_context3(codec));
  state->frame.reset(av_frame_alloc());
  state->packet.reset(av_packet_alloc());
  if (!state->context || !state->frame || !state->packet) return decoderError("out of memory");
  state->context->flags |= AV_CODEC_FLAG_LOW_DELAY; // output each frame as soon as it is decoded
  state->context->thread_count = 1;                 // frame threads would hold frames back
  if (int status = avcodec_open2(state->context.get(), codec, nullptr); status < 0) {
    return decoderError("cannot open h264: " + avError(status));
  }
  return VideoDecoder(std::move(state));
}

Result<bool> VideoDecoder::decode(std::span<const uint8_t> data) {
  State& s = *state_;
  if (data.empty()) return false;
  if (data.size() > size_t(INT32_MAX) - AV_INPUT_BUFFER_PADDING_SIZE) return decoderError("packet too large");
  AVPacket* packet = s.packet.get();
  if (int status = av_new_packet(packet, int(data.size())); status < 0) return decoderError(avError(status));
  std::memcpy(packet->data, data.data(), data.size()); // av_new_packet zeroes the padding the parser reads
  int sent = avcodec_send_packet(s.context.get(), packet);
  av_packet_unref(packet);
  if (sent < 0 && sent != AVERROR(EAGAIN)) return decoderError("rejected packet: " + avError(sent));

  bool got = false;
  for (;;) {
    int status = avcodec_receive_frame(s.context.get(), s.frame.get());
    if (status == AVERROR(EAGAIN) || status == AVERROR_EOF) break;
    if (status < 0) return decoderError(avError(status));
    AVFrame* frame = s.frame.get();
    if (frame->width <= 0 || frame->height <= 0 || uint32_t(frame->width) > kMaxVideoSide ||
        uint32_t(frame->height) > kMaxVideoSide) {
      av_frame_unref(frame);
      return decoderError("frame size outside [1, 16384]");
    }
    s.toRgba.reset(sws_getCachedContext(s.toRgba.release(), frame->width, frame->height, AVPixelFormat(frame->format),
                                        frame->width, frame->height, AV_PIX_FMT_RGBA, kSwsToRgbaFlags, nullptr, nullptr,
                                        nullptr));
    if (!s.toRgba) {
      av_frame_unref(frame);
      return decoderError("no conversion from pixel format " + std::to_string(frame->format) + " to RGBA");
    }
    int space = frame->colorspace == AVCOL_SPC_BT709 ? SWS_CS_ITU709 : SWS_CS_ITU601;
    const int* coefficients = sws_getCoefficients(space);
    int fullRange = frame->color_range == AVCOL_RANGE_JPEG ? 1 : 0;
    sws_setColorspaceDetails(s.toRgba.get(), coefficients, fullRange, coefficients, 1, 0, 1 << 16, 1 << 16);
    s.width = uint32_t(frame->width);
    s.height = uint32_t(frame->height);
    s.image.assign(size_t(s.width) * s.height * 4, 0);
    uint8_t* target[1] = {s.image.data()};
    const int targetStride[1] = {int(s.width * 4)};
    sws_scale(s.toRgba.get(), frame->data, frame->linesize, 0, frame->height, target, targetStride);
    av_frame_unref(frame);
    got = true;
  }
  return got;
}

} // namespace mirage::stream
