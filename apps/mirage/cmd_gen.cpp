// mirage gen: procedural test scenes written as GLB (or binary PLY, like a scanner's output), and
// synthetic scans (`gen points`: a point cloud PLY sampled from a mesh scene).
#include <chrono>
#include <filesystem>
#include <memory>
#include <string>

#include <fmt/core.h>

#include "cmd_list.h"
#include "commands.h"
#include "mirage/io/generate.h"
#include "mirage/io/gltf_write.h"
#include "mirage/io/ply_write.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

struct GenArgs {
  std::string kind, output;
  uint32_t seed = 1;
  uint64_t size = 0;
  std::string mesh;       // grid: the scene (file or gen:KIND...) repeated; points: the surface sampled
  uint32_t instances = 0; // grid: number of copies
  uint64_t points = 0;    // points: how many
  uint64_t triangles = 0; // many: triangles per mesh (0 = the default)
};

// `gen many`: --size meshes of --triangles each (io::ManyOptions), written whole.
Result<Scene> manyScene(const GenArgs& args) {
  auto o = io::parseManySize(std::to_string(args.size), args.seed);
  if (!o) return o.error();
  if (args.triangles) {
    auto t = io::parseManySize(fmt::format("{}x{}", o->count, args.triangles), args.seed);
    if (!t) return t.error();
    o = t;
  }
  return io::generateMany(*o);
}

// `gen grid`: the seed's benchmark scenes (e.g. 2500 copies of a 1M-triangle mesh) as a file, so
// `mirage build grid.glb` bakes the mesh once and keeps the copies as instances.
Result<Scene> gridScene(const GenArgs& args) {
  if (args.mesh.empty()) return Error{"gen grid needs --mesh FILE (or gen:KIND[:SIZE[:SEED]])"};
  if (args.instances < 1 || args.instances > (1u << 22)) return Error{"--instances must be in 1..4194304"};
  auto scene = loadSceneArgument(args.mesh);
  if (!scene) return scene;
  repeatOnGrid(*scene, args.instances);
  scene->source = fmt::format("grid of {} x {}", args.instances, scene->source);
  return scene;
}

// `gen points`: a scanner-like PLY (xyz, normals, colours, no faces) for the surfel sampler's
// point-cloud paths, without downloading a scan.
Result<Scene> pointsScene(const GenArgs& args, double& surfaceArea) {
  if (args.mesh.empty()) return Error{"gen points needs --mesh FILE (or gen:KIND[:SIZE[:SEED]]) to sample"};
  if (args.points < 1 || args.points >= (1ull << 32)) return Error{"--points must be in 1..4294967295"};
  auto scene = loadSceneArgument(args.mesh);
  if (!scene) return scene;
  return io::samplePointCloud(*scene, args.points, args.seed, &surfaceArea);
}

void runGen(const GenArgs& args) {
  namespace fs = std::filesystem;
  // Check the destination before spending seconds generating a scene that cannot be written.
  fs::path out = args.output, dir = out.parent_path().empty() ? fs::path(".") : out.parent_path();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return fail(makeError(args.output, "output directory does not exist"));
  if (fs::is_directory(out, ec)) return fail(makeError(args.output, "is a directory"));
  if (out.extension() != ".glb" && out.extension() != ".ply")
    return fail(makeError(args.output, "unsupported output extension (expected .glb or .ply)"));

  auto start = std::chrono::steady_clock::now();
  if (args.kind != "grid" && args.instances) return fail("--instances belongs to `gen grid`");
  if (args.kind != "grid" && args.kind != "points" && !args.mesh.empty())
    return fail("--mesh belongs to `gen grid` and `gen points`");
  if (args.kind != "points" && args.points) return fail("--points belongs to `gen points`");
  if (args.kind != "many" && args.triangles) return fail("--triangles belongs to `gen many`");
  if (args.kind == "points" && out.extension() != ".ply")
    return fail(makeError(args.output, "gen points writes a .ply"));
  double surfaceArea = 0.0;
  Result<Scene> scene = args.kind == "grid"     ? gridScene(args)
                        : args.kind == "points" ? pointsScene(args, surfaceArea)
                        : args.kind == "many"   ? manyScene(args)
                                                : io::generateScene(args.kind, args.seed, args.size);
  if (!scene) return fail(scene.error());
  double genSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  io::PlyWriteOptions plyOptions;
  plyOptions.normals = plyOptions.colors = args.kind == "points"; // a scan: normals and colours per point
  Status written = out.extension() == ".ply" ? io::writePly(*scene, out, plyOptions) : io::writeGlb(*scene, out);
  if (!written) return fail(written.error());
  double totalSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (args.kind == "points")
    fmt::print("wrote {}: {} points on {} (surface area {:.6g}) seed {}, {} bytes ({:.2f}s, generate {:.2f}s)\n",
               args.output, scene->meshes[0].positions.size(), args.mesh, surfaceArea, args.seed,
               fs::file_size(out, ec), totalSeconds, genSeconds);
  else
    fmt::print("wrote {}: {} seed {}, {} triangles ({} unique), {} instances, {} meshes, {} bytes ({:.2f}s, "
               "generate {:.2f}s)\n",
               args.output, args.kind, args.seed, scene->instancedTriangleCount(), scene->meshTriangleCount(),
               scene->instances.size(), scene->meshes.size(), fs::file_size(out, ec), totalSeconds, genSeconds);
}

} // namespace

void addGenCommand(CLI::App& app) {
  auto args = std::make_shared<GenArgs>();
  CLI::App* cmd = app.add_subcommand("gen", "Generate a procedural scene (deterministic per seed) as GLB");
  cmd->add_option("kind", args->kind,
                  "city | terrain | blob | layers (stacked blended quads) | grid (copies of --mesh) | points (a scan "
                  "of --mesh: PLY point cloud) | many (distinct blobs on a grid; bake gen:many:COUNTxTRIANGLES "
                  "directly to keep the memory of a few meshes)")
      ->required();
  cmd->add_option("-o,--output", args->output, "Output .glb (scene with instances) or .ply (binary, instances baked)")
      ->required();
  cmd->add_option("--seed", args->seed, "Random seed")->capture_default_str();
  cmd->add_option(
      "--size", args->size,
      "city: blocks per side (default 4); terrain: vertices per side (default 1024); "
      "blob: subdivision levels (default 8); layers: quads (default 8); many: meshes (default 16); 0 = default");
  cmd->add_option("--triangles", args->triangles, "many: triangles per mesh (default 100000)");
  cmd->add_option("--mesh", args->mesh,
                  "grid: scene file or gen:KIND[:SIZE[:SEED]] to repeat; points: the surface to sample");
  cmd->add_option("--points", args->points, "points: number of points (uniform over the surface)");
  cmd->add_option("--instances", args->instances, "grid: number of copies on a square grid (e.g. 2500)");
  cmd->callback([args] { runGen(*args); });
}

} // namespace mirage::cli
