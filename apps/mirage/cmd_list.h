#pragma once
// Subcommands defined in their own cmd_*.cpp; registerCommands (commands.cpp) calls these.
#include <string>

#include <CLI/CLI.hpp>

namespace mirage::stream {
struct TessellationConfig;
enum class ParticlePatches;
} // namespace mirage::stream
namespace mirage::render {
enum class AtlasVisibilityMethod;
}

namespace mirage::cli {

// mirage info --devices | FILE [--json]
void addInfoCommand(CLI::App& app);
// mirage render INPUT -o out.png [--camera ...] [--size WxH] [--exr out.exr] [--stats] [--json]
void addRenderCommand(CLI::App& app);
// mirage demo [--out DIR]: generate scenes, render views, report.
void addDemoCommand(CLI::App& app);
// mirage bench render ...: GPU timings.
void addBenchCommand(CLI::App& app);
// mirage bench surfels FILE: surfel splatting throughput (cmd_render_surfels.cpp); a bench subcommand.
void addBenchSurfelsCommand(CLI::App& bench);
// mirage bench rays SCENE [--backend embree|vulkan|all] [--rays N] (cmd_bench_rays.cpp).
void addBenchRaysCommand(CLI::App* bench);
// mirage bench surfels-sort (cmd_bench_surfels.cpp), added under `bench`.
void addBenchSurfelsSortCommand(CLI::App& bench);
// mirage bench surfels-sampler INPUT [--disc-raster all] (cmd_bench_surfels.cpp), added under `bench`.
void addBenchSurfelsSamplerCommand(CLI::App& bench);
// mirage bench surfels-points SCAN.ply (cmd_bench_surfel_points.cpp), added under `bench`.
void addBenchSurfelPointsCommand(CLI::App& bench);
// mirage bench particles FX.toml --count N --sim cpu|gpu (cmd_bench_particles.cpp), added under `bench`.
void addBenchParticlesCommand(CLI::App& bench);
// mirage bench stream SCENE ... (cmd_bench_stream.cpp), added under `bench`.
void addBenchStreamCommand(CLI::App& bench);
// mirage particles FX.toml -o out.png [--scene S] [--frames N] ... (cmd_particles.cpp).
void addParticlesCommand(CLI::App& app);
// mirage build INPUT... -o scene.mrg; mirage verify scene.mrg.
void addBuildCommand(CLI::App& app);
// mirage compare A B [--json]: PSNR / SSIM / MAE between two images.
void addCompareCommand(CLI::App& app);
// mirage gen city|terrain|blob|layers|grid|points -o OUT.glb|OUT.ply [--seed N] [--size N]: write a procedural scene.
void addGenCommand(CLI::App& app);
// mirage surfels INPUT -o out.ply|out.mrg [--count N] [--resolution R] [--views V] [--reference]
void addSurfelsCommand(CLI::App& app);
// mirage view SCENE [--camera ...] [--path P --screenshot OUT.png --exit-after-path] (cmd_view.cpp).
void addViewCommand(CLI::App& app);
// mirage serve SCENE --token-file F ... / mirage client ws://HOST:PORT --token T ... (cmd_stream.cpp).
void addStreamCommands(CLI::App& app);
// --max-patch-edge, --max-triangles: the stream scene's tessellation (serve, bench stream; cmd_stream.cpp).
void bindTessellation(CLI::App& cmd, stream::TessellationConfig& config);
// --visibility auto|compute|hardware (serve, bench stream): how the server finds visible patches.
void bindVisibility(CLI::App& cmd, render::AtlasVisibilityMethod& method);
// --encode-workers, --encoder-threads (serve, bench stream): the frame workers, x264's slice threads.
void bindEncoding(CLI::App& cmd, uint32_t& workers, uint32_t& threads);
// --particles FX.toml, --particle-patches merged|each (serve, bench stream): a streamed particle effect.
void bindParticles(CLI::App& cmd, std::string& effect, stream::ParticlePatches& patches);
// --atlas-fill's help (serve, bench stream).
inline constexpr const char* kAtlasFillHelp =
    "Share of the atlas the visible patches' blocks may want; past it every patch's level bias is lowered "
    "alike (0: no fitting)";
// --bitrate-scope's help (serve, bench stream).
inline constexpr const char* kBitrateScopeHelp =
    "What --bitrate covers: link (every section of a frame; the video gets what the patch and particle sections "
    "leave) or video (the atlas video alone)";
// mirage pvs / pvs-eval: GVS++ potentially visible sets per view cell (cmd_pvs.cpp).
void addPvsCommands(CLI::App& app);

// mirage info FILE [--materials FILE.toml] (scene summary; with a material file applied, every
// material and where it came from).
void infoFile(const std::string& path, bool json, const std::string& materials);

} // namespace mirage::cli
