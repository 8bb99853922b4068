// Streamed particles (docs/stream.md, "Particles"): the server's frames (texture merging: one block
// per visible look; one per particle without it), the simulation's steps per frame, the client's
// image against local rendering of the same effect, and the client's errors.
#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include <fmt/format.h>

#include "gpu_test.h"
#include "loopback_server.h"
#include "mirage/core/image_metrics.h"
#include "mirage/particles/render.h"
#include "mirage/runtime/scene.h"
#include "mirage/stream/client_view.h"
#include "mirage/stream/session.h"
#include "mirage/stream/transport.h"
#include "test_support.h"

namespace mirage::stream {
namespace {

constexpr uint32_t kParticleViewWidth = 256, kParticleViewHeight = 144;
const std::string kSmoke = std::string(MIRAGE_SOURCE_DIR) + "/examples/particles/smoke.toml";

// A flat 20 x 20 m ground (OBJ) under the effect: the scene is cheap, and the smoke rises above its
// bounds (so the particle grid and the client's clip planes must take it in).
std::string groundFile() {
  static const std::string path = [] {
    auto file = test::tempDir("particle_stream") / "ground.obj";
    std::ofstream out(file);
    out << "v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\nvn 0 1 0\nf 1//1 4//1 3//1\nf 1//1 3//1 2//1\n";
    return file.string();
  }();
  return path;
}

// Three views of the smoke column, from the side and from closer below its top.
std::vector<render::Camera> smokeCameras() {
  std::vector<render::Camera> out;
  for (glm::vec3 eye : {glm::vec3(6.0f, 3.0f, 8.0f), glm::vec3(-5.0f, 2.0f, 6.0f), glm::vec3(2.0f, 1.5f, 4.0f)}) {
    render::Camera c;
    c.eye = eye;
    c.target = {0.0f, 2.5f, 0.0f};
    c.fovYDegrees = 60.0f;
    out.push_back(c);
  }
  return out;
}

std::unique_ptr<StreamScene> openSmokeScene(gpu::Context& ctx) {
  StreamSceneOptions so;
  so.input = groundFile();
  so.particles = kSmoke;
  so.atlasSize = 2048;
  auto scene = openStreamScene(ctx, so);
  EXPECT_TRUE(scene) << scene.error().message;
  return scene ? std::move(*scene) : nullptr;
}

Pose poseOf(const render::Camera& camera, uint32_t sequence) {
  Pose p;
  p.sequence = sequence;
  p.camera = p.predicted = toProtocolCamera(camera);
  p.viewportWidth = kParticleViewWidth;
  p.viewportHeight = kParticleViewHeight;
  return p;
}

} // namespace

class StreamParticles : public test::GpuTest {};

namespace {

TEST_F(StreamParticles, MergedShadesOneBlockPerVisibleLook) {
  auto scene = openSmokeScene(context());
  ASSERT_TRUE(scene);
  ASSERT_TRUE(scene->looks);
  EXPECT_EQ(scene->looks->lookCount(), 16u) << "smoke: one system, a 4 x 4 sheet";
  std::unique_ptr<ClientStream> streams[2];
  for (ParticlePatches mode : {ParticlePatches::Merged, ParticlePatches::Each}) {
    ClientStreamConfig config;
    config.particlePatches = mode;
    auto client = ClientStream::create(*scene, config);
    ASSERT_TRUE(client) << client.error().message;
    streams[int(mode)] = std::move(*client);
  }
  std::set<uint32_t> held[2]; // the looks each client holds, mirrored from the frames
  uint32_t sequence = 0;
  for (const render::Camera& camera : smokeCameras()) {
    ++sequence;
    StreamFrameStats stats[2];
    for (int m = 0; m < 2; ++m) {
      auto frame = streams[m]->produceFrame(*scene, poseOf(camera, sequence), &stats[m]);
      ASSERT_TRUE(frame) << frame.error().message;
      const ParticleFrameStats& st = stats[m].particles;
      EXPECT_GT(st.visible, 50u);
      EXPECT_EQ(frame->particles.size(), st.visible);
      std::set<uint32_t> used;
      for (const StreamParticle& p : frame->particles) used.insert(p.look);
      EXPECT_EQ(st.looks, used.size()) << "a block asked for per look used";
      EXPECT_EQ(st.colourOnly, 0u) << "the 512 atlas holds them";
      // Every particle refers to a look it was sent or the client holds from the frame before.
      std::set<uint32_t> sent;
      for (const ParticleLook& l : frame->looks) {
        sent.insert(l.id);
        EXPECT_NE(l.blockLog2, kColourOnlyBlock);
        EXPECT_LE(l.blockLog2, kParticleMaxBlockLog2);
      }
      for (uint32_t look : used) EXPECT_TRUE(sent.count(look) || held[m].count(look)) << "look " << look;
      held[m] = used;
      EXPECT_GT(st.texels, 0u);
      EXPECT_LE(st.texels, uint64_t(st.looks) * 1365) << "a block of 32 and its mips, at most";
    }
    // Texture merging: one block per look of the 16; one per particle otherwise.
    EXPECT_LE(stats[0].particles.looks, 16u);
    EXPECT_EQ(stats[1].particles.looks, stats[1].particles.visible);
    EXPECT_EQ(stats[0].particles.visible, stats[1].particles.visible) << "the same simulation and views";
    EXPECT_GT(stats[1].particles.texels, 5 * stats[0].particles.texels);
    std::printf("frame %u: %u particles visible; merged %u looks, %llu texels; each %llu texels\n", sequence,
                stats[0].particles.visible, stats[0].particles.looks, (unsigned long long)stats[0].particles.texels,
                (unsigned long long)stats[1].particles.texels);
  }
}

TEST_F(StreamParticles, FrameNShowsTheEffectAfterNSteps) {
  auto scene = openSmokeScene(context());
  ASSERT_TRUE(scene);
  ClientParticles particles(*scene->effect, ParticlePatches::Merged);
  particles::Simulation reference = particles::makeSimulation(*scene->effect, kStreamParticleStep);
  ParticleView view{smokeCameras()[0].view(), smokeCameras()[0].projection(16.0f / 9.0f), 144.0f};
  for (uint32_t frame : {1u, 2u, 5u, 5u, 9u}) { // a frame produced again is not stepped again
    particles.prepare(*scene->looks, frame, {&view, 1});
    EXPECT_EQ(particles.steps(), frame);
    while (reference.pools[0].step <
           particles.steps() + particles::prewarmSteps(scene->effect->systems[0], kStreamParticleStep))
      particles::step(reference);
    std::vector<shaderio::RenderParticle> expected(particles::liveParticles(reference));
    particles::writeRenderParticles(reference, expected);
    ASSERT_EQ(particles.records().size(), expected.size());
    for (size_t i = 0; i < expected.size(); ++i) {
      EXPECT_EQ(particles.records()[i].id, expected[i].id);
      EXPECT_EQ(particles.records()[i].position, expected[i].position);
    }
  }
}

// The client's image of each camera against the forward renderer's with the same effect at the
// same step, every particle a billboard in both.
void expectClientMatchesLocal(gpu::Context& ctx, ParticlePatches mode, double minSsim) {
  auto scene = openSmokeScene(ctx);
  ASSERT_TRUE(scene);
  ClientStreamConfig config; // lossless zstd tiles
  config.particlePatches = mode;
  auto client = ClientStream::create(*scene, config);
  ASSERT_TRUE(client) << client.error().message;
  auto view = StreamView::create(ctx, sceneWelcome(*scene, AtlasCodec::ZstdTiles));
  ASSERT_TRUE(view) << view.error().message;
  auto local = runtime::Scene::open(ctx, {.input = groundFile()});
  ASSERT_TRUE(local) << local.error().message;
  auto effect = particles::EffectPlayer::create(ctx, *scene->effect, particles::SimKind::Cpu, kStreamParticleStep);
  ASSERT_TRUE(effect) << effect.error().message;
  ASSERT_TRUE((*effect)->draw()->setSettings({/*splatBelowPixels=*/0.0f}));
  uint32_t sequence = 0;
  for (const render::Camera& camera : smokeCameras()) {
    auto frame = (*client)->produceFrame(*scene, poseOf(camera, ++sequence));
    ASSERT_TRUE(frame) << frame.error().message;
    ASSERT_TRUE((*view)->apply(*frame));
    auto streamed = (*view)->render(camera, kParticleViewWidth, kParticleViewHeight);
    ASSERT_TRUE(streamed) << streamed.error().message;
    (*effect)->step(1); // frame n: n steps
    runtime::View lv;
    lv.camera = particles::clipAround(camera, (*local)->bounds(), (*effect)->bounds());
    lv.width = kParticleViewWidth;
    lv.height = kParticleViewHeight;
    lv.particles = (*effect)->draw();
    auto reference = (*local)->render(lv);
    ASSERT_TRUE(reference) << reference.error().message;
    runtime::View bare = lv; // the ground alone: the particles must make a difference
    bare.particles = nullptr;
    auto ground = (*local)->render(bare);
    ASSERT_TRUE(ground) << ground.error().message;
    double s = ssim(streamed->srgb, reference->srgb), p = psnr(streamed->srgb, reference->srgb);
    std::printf("%s frame %u: SSIM %.4f PSNR %.2f dB against local; without particles SSIM %.4f\n",
                nameOf(kParticlePatchesNames, mode), sequence, s, p, ssim(ground->srgb, reference->srgb));
    EXPECT_GE(s, minSsim) << "frame " << sequence;
    EXPECT_LT(ssim(ground->srgb, reference->srgb), minSsim) << "the effect shows";
    EXPECT_GT((*view)->particleCount(), 50u);
  }
}

// Measured on lavapipe: SSIM 0.997-0.999 in both modes, 0.79-0.93 for the ground without the effect.
TEST_F(StreamParticles, MergedClientMatchesLocalRendering) {
  expectClientMatchesLocal(context(), ParticlePatches::Merged, 0.995);
}

TEST_F(StreamParticles, EachClientMatchesLocalRendering) {
  expectClientMatchesLocal(context(), ParticlePatches::Each, 0.995);
}

// A particle of a look with a block shows the block's texels times its colour, one of a colour-only
// look the look's colour times its colour, at the particle's place on screen.
TEST_F(StreamParticles, ClientDrawsBlockAndColourOnlyLooks) {
  Welcome w;
  w.sceneMin = glm::vec3(-1.0f);
  w.sceneMax = glm::vec3(1.0f);
  w.positionStep = positionGridStep(w.sceneMin, w.sceneMax, 16);
  w.atlasWidth = w.atlasHeight = 128;
  w.codec = AtlasCodec::ZstdTiles;
  w.patchCount = 10;
  auto view = StreamView::create(context(), w);
  ASSERT_TRUE(view) << view.error().message;
  // Look 1's block (16 high at (32, 0)): level 0 and its mips all blue, the rest of the atlas black.
  ImageRGBA8 atlas{128, 128, std::vector<uint8_t>(128 * 128 * 4, 0)};
  for (uint32_t y = 0; y < 16; ++y)
    for (uint32_t x = 32; x < 64; ++x) atlas.at(x, y)[2] = atlas.at(x, y)[3] = 255;
  ASSERT_TRUE((*view)->renderer().updateAtlas(atlas));
  Frame f;
  f.sequence = 1;
  f.looks = {{1, 32, 0, 4, {}}, {2, 0, 0, kColourOnlyBlock, {255, 0, 0, 255}}};
  glm::vec3 origin(-1.0f);
  float step = 1.0f / 1024.0f;
  f.particleOrigin = origin;
  f.particleStep = step;
  f.particles = {quantizeParticle({-0.5f, 0.0f, 0.0f}, 0.6f, 0.3f, 0xff00ffffu, 1, origin, step), // yellow x blue
                 quantizeParticle({0.5f, 0.0f, 0.0f}, 0.6f, 0.0f, 0xffffffffu, 2, origin, step)}; // white x red
  ASSERT_TRUE((*view)->apply(f));
  render::Camera camera;
  camera.eye = {0.0f, 0.0f, 3.0f};
  camera.target = {0.0f, 0.0f, 0.0f};
  camera.fovYDegrees = 60.0f;
  auto out = (*view)->render(camera, 96, 64);
  ASSERT_TRUE(out) << out.error().message;
  // x = -0.5 and 0.5 at depth 3, fov 60, 96 x 64: pixels 48 -+ 0.5 / (3 tan 30 * 1.5) * 48 = 48 -+ 9.2.
  const uint8_t* a = out->srgb.at(38, 32);
  const uint8_t* b = out->srgb.at(57, 32);
  const uint8_t* between = out->srgb.at(48, 32);
  EXPECT_LE(a[0] + a[1], 6) << "yellow x blue: black";
  EXPECT_LE(a[2], 6) << "yellow x blue: black";
  EXPECT_GE(b[0], 250) << "white x red: red";
  EXPECT_LE(b[1] + b[2], 6);
  EXPECT_NEAR(between[0], 39, 6) << "the background between them";
  f.particles[0].rgba = {255, 255, 255, 255}; // white x blue
  f.looks.clear();
  f.sequence = 2;
  ASSERT_TRUE((*view)->apply(f));
  out = (*view)->render(camera, 96, 64);
  ASSERT_TRUE(out) << out.error().message;
  EXPECT_GE(out->srgb.at(38, 32)[2], 250) << "white x blue: blue, from the look held";
}

TEST_F(StreamParticles, ClientRefusesParticlesOfLooksItDoesNotHold) {
  Welcome w;
  w.sceneMin = glm::vec3(-1.0f);
  w.sceneMax = glm::vec3(1.0f);
  w.positionStep = positionGridStep(w.sceneMin, w.sceneMax, 16);
  w.atlasWidth = w.atlasHeight = 128;
  w.codec = AtlasCodec::ZstdTiles;
  w.patchCount = 10;
  auto fresh = [&] {
    auto v = StreamView::create(context(), w);
    EXPECT_TRUE(v) << v.error().message;
    return std::move(*v);
  };
  auto expectError = [](const Status& s, const std::string& part) {
    ASSERT_FALSE(s) << "accepted, expected an error with '" << part << "'";
    EXPECT_NE(s.error().message.find(part), std::string::npos) << s.error().message;
  };
  Frame f;
  f.sequence = 1;
  f.looks = {{3, 32, 0, 4, {}}};
  f.particles = {quantizeParticle(glm::vec3(0.0f), 0.5f, 0.0f, 0xffffffffu, 3, glm::vec3(0.0f), 1.0f)};
  auto v = fresh();
  ASSERT_TRUE(v->apply(f));
  EXPECT_EQ(v->particleCount(), 1u);
  EXPECT_EQ(v->lookCount(), 1u);
  Frame next = f; // look 3 held: no entry needed
  next.sequence = 2;
  next.looks.clear();
  ASSERT_TRUE(v->apply(next));
  Frame none;
  none.sequence = 3;
  ASSERT_TRUE(v->apply(none));
  EXPECT_EQ(v->particleCount(), 0u);
  EXPECT_EQ(v->lookCount(), 0u) << "looks no particle used are dropped";
  next.sequence = 4;
  expectError(v->apply(next), "Frame 4: particle 0 of look 3, which the client does not hold");
  v = fresh();
  Frame outside = f;
  outside.looks[0].blockX = 128; // inside the protocol's limit, outside this atlas
  expectError(v->apply(outside), "look 3: block 32x16 at (128, 0) outside the 128x128 atlas");
  outside.looks[0].blockX = 112; // level 0 inside, its mips beside it not
  expectError(fresh()->apply(outside), "look 3: block 32x16 at (112, 0) outside");
}

// A server streaming particles to two clients: one that sends garbage is closed, the other goes on
// getting frames with particles.
TEST_F(StreamParticles, BadInputClosesOnlyThatClient) {
  using namespace std::chrono_literals;
  test::StreamTestServer server(groundFile(), AtlasCodec::ZstdTiles, test::kStreamToken, 512, kSmoke);
  ASSERT_TRUE(server.server);
  ClientConfig config;
  config.hello = {test::kStreamToken, kCapabilityZstdTiles | kCapabilityZstdPatches, kParticleViewWidth,
                  kParticleViewHeight, false};
  auto frameFor = [&](TransportClient& client, uint32_t sequence) -> Frame {
    EXPECT_TRUE(client.send(poseOf(smokeCameras()[sequence % 3], sequence)));
    for (int i = 0; i < 10; ++i) {
      Result<Message> m = client.receive(30s);
      if (!m) {
        ADD_FAILURE() << m.error().message;
        return {};
      }
      if (const Frame* f = std::get_if<Frame>(&*m); f && f->poseSequence == sequence) return *f;
    }
    ADD_FAILURE() << "no frame answered pose " << sequence;
    return {};
  };
  TransportClient good, bad;
  ASSERT_TRUE(good.connect(server.url(), config).ok());
  ASSERT_TRUE(bad.connect(server.url(), config).ok());
  EXPECT_GT(frameFor(good, 1).particles.size(), 50u);
  EXPECT_GT(frameFor(bad, 1).particles.size(), 50u);
  std::vector<uint8_t> garbage = encodeMessage(poseOf(smokeCameras()[0], 2));
  const uint8_t infinity[4] = {0, 0, 0x80, 0x7f}; // camera.eye.x (after header, sequence, time)
  std::copy(infinity, infinity + 4, garbage.begin() + kMessageHeaderBytes + 12);
  ASSERT_TRUE(bad.sendBytes(garbage));
  std::string reason;
  for (int i = 0; i < 10 && reason.empty(); ++i) {
    Result<Message> m = bad.receive(30s);
    if (!m)
      reason = m.error().message;
    else if (const Close* close = std::get_if<Close>(&*m))
      reason = close->reason;
  }
  EXPECT_NE(reason.find("not a finite number"), std::string::npos) << reason;
  for (int i = 0; i < 500 && bad.connected(); ++i) std::this_thread::sleep_for(10ms);
  EXPECT_FALSE(bad.connected()) << "the server did not close the connection";
  for (uint32_t sequence = 2; sequence <= 3; ++sequence)
    EXPECT_GT(frameFor(good, sequence).particles.size(), 50u) << "the other client is still served";
}

} // namespace
} // namespace mirage::stream
