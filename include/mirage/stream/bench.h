#pragma once
// `mirage bench stream` (docs/stream.md, "Measurements"): the server's frame production for N
// clients and one client's view of it, in one process without the network, along a camera path.
// The N clients are served as the server serves them: this thread runs each client's GPU stages in
// turn, worker threads encode (frame_workers.h), one frame in flight per client; their throughput
// (client frames per second of the server's wall time) gives the clients one GPU serves at 30 Hz.
// Per frame: server time (wall per stage, and GPU), atlas texels shaded, bytes by kind; the client's
// image against the forward renderer's of the same camera (SSIM, PSNR), with a round trip of K frames:
// the client draws camera i from the frames answering poses up to i - K (each pose predicting the
// camera it will be shown at: the path's camera i + K, an exact prediction; say so when comparing
// with systems that predict).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/stream/protocol.h"
#include "mirage/stream/session.h"
#include "mirage/stream/tessellate.h"

namespace mirage::stream {

struct StreamBenchConfig {
  std::string input = "gen:city:4"; // scene file or gen:KIND
  std::string materials;
  std::string path = "orbit:60"; // camera JSON or orbit:N
  uint32_t width = 1920, height = 1080;
  uint32_t atlasSize = 2048;
  TessellationConfig tessellation;
  AtlasCodec codec = AtlasCodec::H264;
  uint32_t bitrateKbps = 20000;
  bool linkBudget = true;      // ClientStreamConfig::linkBudget: the bitrate covers every section
  uint32_t fps = 60;           // frames per second the path is played at (bitrates, rate control)
  uint32_t clients = 1;        // clients served at once, each along the path from its own offset
  uint32_t encodeWorkers = 0;  // threads encoding while the GPU prepares the next client (0: frameWorkerCount's)
  uint32_t encoderThreads = 0; // H.264: x264's slice threads per encoder (0: x264 picks)
  uint32_t latencyFrames = 0;  // round trip, in frames
  float levelBias = 0.0f;
  float atlasFill = ClientStreamConfig{}.atlasFill; // share of the atlas level selection fits the blocks to (0: none)
  uint32_t positionBits = 20;                       // StreamSceneOptions::positionBits
  render::AtlasVisibilityMethod visibility = render::AtlasVisibilityMethod::Auto; // StreamSceneOptions::visibility
  // Client 0 draws every frame and is compared with local rendering. The clock of the throughput
  // stops meanwhile, but every client's frame of a path step is finished before client 0 draws:
  // measure throughput without (nothing then waits on the pipeline but its own rule).
  bool quality = true;
  // A particle effect streamed with the scene (StreamSceneOptions::particles) and how its looks get
  // blocks. The local rendering draws the same effect at the step of the frame the client drew
  // last (frame n: n steps), every particle a billboard as the client draws them.
  std::string particles;
  ParticlePatches particlePatches = ParticlePatches::Merged;
};

struct StreamBenchFrame {
  // Server, per client frame (averaged over the clients served that frame): wall time of the
  // frame's work (StreamFrameStats::totalMs) and of its stages, GPU time.
  double serverMs = 0, visibilityMs = 0, shadingMs = 0, readbackMs = 0, encodeMs = 0, patchesMs = 0;
  double levelsMs = 0, allocateMs = 0, blocksMs = 0; // StreamFrameStats' parts of shadingMs
  double gpuVisibilityMs = 0, gpuShadingMs = 0, gpuConvertMs = 0;
  std::map<std::string, double> gpuPasses; // StreamFrameStats::gpuPasses by name, summed within a frame
  uint64_t shadedTexels = 0;
  uint32_t visiblePatches = 0, colourOnly = 0;
  ParticleFrameStats particles; // client 0's
  float levelBias = 0.0f;       // client 0's, after fitting the atlas
  // Client 0.
  // The patch section (removed ids, entries, colours) as sent and before zstd; the atlas payload.
  uint64_t geometryBytes = 0, geometryRawBytes = 0, atlasBytes = 0;
  uint64_t particleBytes = 0, particleRawBytes = 0; // the particle section as sent, and before zstd
  uint32_t videoTargetKbps = 0;                     // StreamFrameStats::videoTargetKbps
  // Entries with positions, block-only entries, removed ids, colours sent.
  uint32_t geometryEntries = 0, blockOnlyEntries = 0, removed = 0, colours = 0;
  double clientApplyMs = 0, clientRenderMs = 0; // decode + upload; drawing (wall, incl. readback)
  double ssim = 0, psnr = 0;                    // against the forward renderer (quality on)
};

struct StreamBenchReport {
  std::string device;
  render::AtlasVisibilityMethod visibility = render::AtlasVisibilityMethod::Hardware; // the method that ran
  TessellationStats tessellation; // the served scene's (instanced triangles before and after)
  uint32_t patches = 0;           // the served scene's
  std::vector<StreamBenchFrame> frames;
  // Means over the frames (the first latencyFrames + 1 frames excluded from quality: nothing has
  // arrived for them yet).
  double meanServerMs = 0, meanGpuMs = 0, meanSsim = 0, minSsim = 0, meanPsnr = 0;
  double megabitsPerSecond = 0; // client 0's bytes at `fps`
  uint32_t encodeWorkers = 0;   // the workers that ran
  double serverSeconds = 0;     // wall time of the server's work (client 0's drawing and comparing excluded)
  double framesPerSecond = 0;   // client frames of all clients / serverSeconds
  double clientsAt30Hz = 0;     // framesPerSecond / 30
};

Result<StreamBenchReport> runStreamBench(gpu::Context& context, const StreamBenchConfig& config);

} // namespace mirage::stream
