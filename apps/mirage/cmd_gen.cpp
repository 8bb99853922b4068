// mirage gen: procedural test scenes written as GLB (or binary PLY, like a scanner's output).
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
  std::string mesh;       // grid: the scene (file or gen:KIND...) repeated
  uint32_t instances = 0; // grid: number of copies
};

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
  if (args.kind != "grid" && (!args.mesh.empty() || args.instances))
    return fail("--mesh and --instances belong to `gen grid`");
  Result<Scene> scene = args.kind == "grid" ? gridScene(args) : io::generateScene(args.kind, args.seed, args.size);
  if (!scene) return fail(scene.error());
  double genSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Status written = out.extension() == ".ply" ? io::writePly(*scene, out) : io::writeGlb(*scene, out);
  if (!written) return fail(written.error());
  double totalSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("wrote {}: {} seed {}, {} triangles ({} unique), {} instances, {} meshes, {} bytes ({:.2f}s, "
             "generate {:.2f}s)\n",
             args.output, args.kind, args.seed, scene->instancedTriangleCount(), scene->meshTriangleCount(),
             scene->instances.size(), scene->meshes.size(), fs::file_size(out, ec), totalSeconds, genSeconds);
}

} // namespace

void addGenCommand(CLI::App& app) {
  auto args = std::make_shared<GenArgs>();
  CLI::App* cmd = app.add_subcommand("gen", "Generate a procedural scene (deterministic per seed) as GLB");
  cmd->add_option("kind", args->kind, "city | terrain | blob | grid (copies of --mesh)")->required();
  cmd->add_option("-o,--output", args->output, "Output .glb (scene with instances) or .ply (binary, instances baked)")
      ->required();
  cmd->add_option("--seed", args->seed, "Random seed")->capture_default_str();
  cmd->add_option("--size", args->size,
                  "city: blocks per side (default 4); terrain: vertices per side (default 1024); "
                  "blob: subdivision levels (default 8); 0 = default");
  cmd->add_option("--mesh", args->mesh, "grid: scene file or gen:KIND[:SIZE[:SEED]] to repeat");
  cmd->add_option("--instances", args->instances, "grid: number of copies on a square grid (e.g. 2500)");
  cmd->callback([args] { runGen(*args); });
}

} // namespace mirage::cli
