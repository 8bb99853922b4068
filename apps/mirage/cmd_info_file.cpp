// mirage info FILE: what a scene file or any Mirage output holds.
#include <algorithm>
#include <filesystem>
#include <map>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "cmd_list.h"
#include "commands.h"
#include "lod_common.h"
#include "mirage/asset/container.h"
#include "mirage/asset/scene_chunk.h"
#include "mirage/io/import.h"
#include "mirage/shading/material_file.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/lod/paged_asset.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/surfel_io.h"
#include "mirage/visibility/pvs_storage.h"
#include "render_common.h"

namespace mirage::cli {

namespace {

nlohmann::json boundsJson(const Bounds& b) {
  return {{"bounds_min", {b.min.x, b.min.y, b.min.z}}, {"bounds_max", {b.max.x, b.max.y, b.max.z}}};
}
std::string boundsText(const Bounds& b) {
  return fmt::format("({:.4g}, {:.4g}, {:.4g}) .. ({:.4g}, {:.4g}, {:.4g})", b.min.x, b.min.y, b.min.z, b.max.x,
                     b.max.y, b.max.z);
}

// Per chunk type in file order: count, stored and raw bytes, zstd levels used.
struct ChunkKind {
  std::string type;
  size_t count = 0, blocked = 0; // blocked: index + separately readable blocks
  uint64_t storedBytes = 0, rawBytes = 0;
  int minLevel = 0, maxLevel = 0;
};

std::vector<ChunkKind> chunkKinds(const asset::AssetReader& reader) {
  std::vector<ChunkKind> kinds;
  for (const asset::ChunkInfo& c : reader.chunks()) {
    std::string type = c.type.str();
    auto it = std::find_if(kinds.begin(), kinds.end(), [&](const ChunkKind& k) { return k.type == type; });
    if (it == kinds.end()) it = kinds.insert(kinds.end(), ChunkKind{type, 0, 0, 0, 0, c.zstdLevel, c.zstdLevel});
    ++it->count;
    it->blocked += c.blocked;
    it->storedBytes += c.storedBytes;
    it->rawBytes += c.rawBytes;
    it->minLevel = std::min(it->minLevel, int(c.zstdLevel));
    it->maxLevel = std::max(it->maxLevel, int(c.zstdLevel));
  }
  return kinds;
}

const char* chunkMeaning(const std::string& type) {
  if (type == asset::chunk::Scene.str()) return "scene: instances, materials, textures";
  if (type == asset::chunk::Mesh.str()) return "mesh geometry";
  if (type == asset::chunk::ClusterDag.str()) return "cluster-LOD DAG, one per mesh";
  if (type == asset::chunk::ClusterPages.str()) return "paged cluster-LOD DAG, one per mesh";
  if (type == asset::chunk::SourceMap.str()) return "source triangle -> level-0 cluster map";
  if (type == asset::chunk::Surfels.str()) return "surfel cloud";
  if (type == asset::chunk::Visibility.str()) return "potentially visible sets";
  if (type == asset::chunk::Meta.str()) return "JSON metadata";
  return "unknown to this build (skipped by readers)";
}

// Every material with its origin and how many meshes use it. The origin is `path` (the scene file
// carries it), "<material file>:<line>" (applied now), or, in a .mrg, "<material file>:<line>
// (baked)" (applied by `mirage build --materials`).
nlohmann::json materialList(const Scene& s, const std::string& path, bool baked) {
  nlohmann::json list = nlohmann::json::array();
  for (size_t i = 0; i < s.materials.size(); ++i) {
    const Material& m = s.materials[i];
    size_t meshes = 0;
    for (const Mesh& mesh : s.meshes) meshes += mesh.material == i;
    const char* alpha[] = {"OPAQUE", "MASK", "BLEND"};
    list.push_back({{"index", i},
                    {"name", m.name},
                    {"model", m.model == ShadingModel::BlinnPhong ? "blinn-phong" : "metallic-roughness"},
                    {"alpha_mode", alpha[int(m.alphaMode)]},
                    {"meshes", meshes},
                    {"origin", m.origin.empty() ? path : m.origin + (baked ? " (baked)" : "")}});
  }
  return list;
}

void printMaterialList(const nlohmann::json& list) {
  for (const nlohmann::json& m : list)
    fmt::print("  material {} \"{}\": {}, {}, {} mesh(es), from {}\n", m["index"].get<size_t>(),
               m["name"].get<std::string>(), m["model"].get<std::string>(), m["alpha_mode"].get<std::string>(),
               m["meshes"].get<size_t>(), m["origin"].get<std::string>());
}

// The cluster-LOD part: levels, clusters and triangles per level, fill, root, bytes per triangle.
bool describeLod(const std::string& path, nlohmann::json& j, bool json) {
  auto a = lod::loadLodAsset(path);
  if (!a) return fail(a.error()), false;
  BuildSummary s = summarize(*a, path);
  if (json) {
    j.update(summaryJson(s)); // at the top level, as before the other chunk kinds were described
    j["instances"] = a->scene.instances.size();
    j["materials"] = a->scene.materials.size();
    j["textures"] = a->scene.textures.size();
    j["lights"] = a->scene.lights.size();
    j["material_list"] = materialList(a->scene, a->scene.source, true);
    return true;
  }
  fmt::print("  cluster-LOD: {} meshes, {} instances, {} materials, {} textures\n", s.meshes, a->scene.instances.size(),
             a->scene.materials.size(), a->scene.textures.size());
  printSummary(s);
  // Baked material files: every material with its origin, and the point lights.
  bool baked = !a->scene.lights.empty() || std::any_of(a->scene.materials.begin(), a->scene.materials.end(),
                                                       [](const Material& m) { return !m.origin.empty(); });
  if (baked) {
    printMaterialList(materialList(a->scene, a->scene.source, true));
    fmt::print("  point lights {}\n", a->scene.lights.size());
  }
  return true;
}

// Paged DAGs, from their chunk indices alone (describeLod has read and checked every page): pages,
// root pages, index (page table) bytes, and the stored page sizes.
bool describePages(const asset::AssetReader& reader, nlohmann::json& j, bool json) {
  auto meshes = lod::openPagedMeshes(reader);
  if (!meshes) return fail(meshes.error()), false;
  uint64_t pages = 0, rootPages = 0, tableBytes = 0;
  std::vector<uint64_t> sizes;
  for (const lod::PagedMesh& m : *meshes) {
    pages += m.table.pages.size();
    rootPages += m.table.rootPageCount;
    tableBytes += m.blocks.indexBytes;
    for (const asset::BlockInfo& b : m.blocks.blocks) sizes.push_back(b.storedBytes);
  }
  std::sort(sizes.begin(), sizes.end());
  uint64_t smallest = sizes.empty() ? 0 : sizes.front(), median = sizes.empty() ? 0 : sizes[sizes.size() / 2],
           largest = sizes.empty() ? 0 : sizes.back();
  if (json) {
    j["pages"] = {{"meshes", meshes->size()},   {"pages", pages},
                  {"root_pages", rootPages},    {"table_bytes", tableBytes},
                  {"page_bytes_min", smallest}, {"page_bytes_median", median},
                  {"page_bytes_max", largest}};
    return true;
  }
  fmt::print("  pages: {} in {} paged meshes ({} root pages, always resident); tables {} bytes; page stored bytes "
             "min {} median {} max {}\n",
             grouped(pages), meshes->size(), rootPages, grouped(tableBytes), grouped(smallest), grouped(median),
             grouped(largest));
  return true;
}

// A scene chunk without DAGs (asset::saveScene): the imported scene as stored.
bool describeScene(const asset::AssetReader& reader, const std::string& path, nlohmann::json& j, bool json) {
  auto bytes = reader.readChunk(asset::chunk::Scene);
  if (!bytes) return fail(bytes.error()), false;
  auto scene = asset::decodeScene(*bytes, path);
  if (!scene) return fail(scene.error()), false;
  if (json) {
    j["scene"] = {{"meshes", scene->meshes.size()},
                  {"instances", scene->instances.size()},
                  {"triangles", scene->meshTriangleCount()},
                  {"materials", scene->materials.size()},
                  {"textures", scene->textures.size()}};
    return true;
  }
  fmt::print("  scene: {} meshes, {} instances, {} triangles, {} materials, {} textures\n", scene->meshes.size(),
             scene->instances.size(), grouped(scene->meshTriangleCount()), scene->materials.size(),
             scene->textures.size());
  return true;
}

// How a SURF chunk is laid out: blocks in prefix order (sizes from its block index), or one flat
// array (files written before blocked chunks: one zstd frame, no progressive reading).
nlohmann::json surfelLayout(const asset::AssetReader& reader, size_t index, uint64_t surfels) {
  const asset::ChunkInfo& info = reader.chunks()[index];
  if (!info.blocked) return {{"layout", "flat"}};
  auto table = reader.readBlockTable(index); // already read whole by readSurfelMrgAll: cannot fail here
  if (!table) return {{"layout", "blocked"}};
  uint64_t largest = 0;
  for (const asset::BlockInfo& b : table->blocks) largest = std::max(largest, b.storedBytes);
  nlohmann::json j = {{"layout", "blocked"},
                      {"blocks", table->blocks.size()},
                      {"index_bytes", table->indexBytes},
                      {"max_block_stored_bytes", largest}};
  if (!table->blocks.empty()) {
    const asset::BlockInfo& first = table->blocks.front();
    j["first_block_surfels"] = table->rawBytes ? first.rawBytes * surfels / table->rawBytes : 0;
    j["first_block_stored_bytes"] = first.storedBytes;
  }
  return j;
}

bool describeSurfels(const asset::AssetReader& reader, const std::string& path, nlohmann::json& j, bool json) {
  auto clouds = surfels::readSurfelMrgAll(path);
  if (!clouds) return fail(clouds.error()), false;
  uint64_t total = 0, blocks = 0, indexBytes = 0, firstBytes = 0, largest = 0, firstSurfels = 0;
  size_t flat = 0, cloud = 0;
  Bounds box;
  nlohmann::json list = nlohmann::json::array();
  for (size_t i = 0; i < reader.chunks().size(); ++i) {
    if (reader.chunks()[i].type != asset::chunk::Surfels) continue;
    const surfels::MeshSurfels& m = (*clouds)[cloud++];
    total += m.cloud.size();
    box.add(m.cloud.box);
    nlohmann::json c = boundsJson(m.cloud.box);
    c["surfels"] = m.cloud.size();
    c["mesh"] = m.mesh == surfels::kWholeScene ? nlohmann::json("scene") : nlohmann::json(m.mesh);
    c["reference_mean_spacing"] = m.cloud.referenceMeanSpacing;
    c.update(surfelLayout(reader, i, m.cloud.size()));
    flat += c["layout"] == "flat";
    blocks += c.value("blocks", uint64_t(0));
    indexBytes += c.value("index_bytes", uint64_t(0));
    firstBytes += c.value("first_block_stored_bytes", uint64_t(0));
    firstSurfels += c.value("first_block_surfels", uint64_t(0));
    largest = std::max(largest, c.value("max_block_stored_bytes", uint64_t(0)));
    list.push_back(c);
  }
  bool wholeScene = clouds->size() == 1 && clouds->front().mesh == surfels::kWholeScene;
  if (json) {
    j["surfels"] = {{"clouds", list}, {"total", total}};
    return true;
  }
  fmt::print("  surfels: {} in {} ({}), box {}\n", grouped(total),
             wholeScene ? "one whole-scene cloud (world space)" : fmt::format("{} clouds", clouds->size()),
             wholeScene ? "render with --surfels" : "one per mesh, object space", boundsText(box));
  if (flat < clouds->size())
    fmt::print("  surfel blocks: {} in prefix order (index {} bytes); preview (first block of each cloud) {} surfels "
               "in {} bytes stored; largest block {} bytes\n",
               grouped(blocks), grouped(indexBytes), grouped(firstSurfels), grouped(firstBytes), grouped(largest));
  if (flat > 0)
    fmt::print("  {} of {} surfel clouds flat (one zstd frame, written before progressive blocks: rewrite with "
               "mirage surfels to stream them)\n",
               flat, clouds->size());
  return true;
}

bool describePvs(const std::string& path, nlohmann::json& j, bool json) {
  auto pvs = vis::loadPvs(path);
  if (!pvs) return fail(pvs.error()), false;
  uint64_t sum = 0, most = 0;
  for (const auto& t : pvs->triangles) sum += t.size(), most = std::max<uint64_t>(most, t.size());
  double mean = pvs->cells.empty() ? 0.0 : double(sum) / double(pvs->cells.size());
  if (json) {
    j["pvs"] = {{"cells", pvs->cells.size()},
                {"scene_triangles", pvs->sceneTriangles},
                {"mean_triangles_per_cell", mean},
                {"max_triangles_per_cell", most}};
    return true;
  }
  fmt::print("  PVS: {} view cells over a scene of {} triangles; visible per cell: mean {} ({:.2f}%), max {}\n",
             pvs->cells.size(), grouped(pvs->sceneTriangles), grouped(uint64_t(mean + 0.5)),
             pvs->sceneTriangles ? 100.0 * mean / double(pvs->sceneTriangles) : 0.0, grouped(most));
  fmt::print("  (render the scene it was baked for with --pvs {})\n", path);
  return true;
}

// Any .mrg: the chunk table by type, then what each kind of chunk holds (each decoded and checked).
void infoMrg(const std::string& path, bool json) {
  auto reader = asset::AssetReader::open(path);
  if (!reader) return fail(reader.error());
  std::vector<ChunkKind> kinds = chunkKinds(*reader);
  auto has = [&](asset::FourCC t) { return reader->find(t).has_value(); };
  std::vector<std::string> holds;
  bool lodAsset = has(asset::chunk::ClusterDag) || has(asset::chunk::ClusterPages);
  if (lodAsset) holds.push_back(has(asset::chunk::ClusterDag) ? "cluster-LOD asset" : "paged cluster-LOD asset");
  if (!lodAsset && has(asset::chunk::Scene)) holds.push_back("scene");
  if (has(asset::chunk::Surfels)) holds.push_back("surfels");
  if (has(asset::chunk::Visibility)) holds.push_back("PVS");
  std::string what = holds.empty() ? "no chunk this build describes" : fmt::format("{}", fmt::join(holds, " + "));
  nlohmann::json j;
  if (json) {
    j["file"] = path;
    j["file_bytes"] = reader->fileBytes();
    j["holds"] = holds;
    nlohmann::json chunks = nlohmann::json::array();
    for (const ChunkKind& k : kinds)
      chunks.push_back({{"type", k.type.substr(1, 4)},
                        {"count", k.count},
                        {"blocked", k.blocked},
                        {"stored_bytes", k.storedBytes},
                        {"raw_bytes", k.rawBytes},
                        {"zstd_level_min", k.minLevel},
                        {"zstd_level_max", k.maxLevel}});
    j["chunks"] = chunks;
  } else {
    fmt::print("{}: {}, {} bytes in {} chunks\n", path, what, grouped(reader->fileBytes()), reader->chunks().size());
    for (const ChunkKind& k : kinds) {
      std::string level = k.maxLevel == 0            ? "raw"
                          : k.minLevel == k.maxLevel ? fmt::format("zstd {}", k.maxLevel)
                                                     : fmt::format("zstd {}..{}", k.minLevel, k.maxLevel);
      if (k.blocked) level += k.blocked == k.count ? ", blocked" : fmt::format(", {} blocked", k.blocked);
      fmt::print("  {} x{:<4} {:>14} bytes stored ({}), {:>14} raw  {}\n", k.type, k.count, grouped(k.storedBytes),
                 level, grouped(k.rawBytes), chunkMeaning(k.type));
    }
  }
  if (lodAsset && !describeLod(path, j, json)) return;
  if (has(asset::chunk::ClusterPages) && !describePages(*reader, j, json)) return;
  if (!lodAsset && has(asset::chunk::Scene) && !describeScene(*reader, path, j, json)) return;
  if (has(asset::chunk::Surfels) && !describeSurfels(*reader, path, j, json)) return;
  if (has(asset::chunk::Visibility) && !describePvs(path, j, json)) return;
  if (json) fmt::print("{}\n", j.dump(2));
}

// A surfel PLY (from mirage surfels): the cloud, not a mesh.
void infoSurfelPly(const std::string& path, bool json) {
  auto cloud = surfels::readSurfelPly(path);
  if (!cloud) return fail(cloud.error());
  if (json) {
    nlohmann::json j = boundsJson(cloud->box);
    j["file"] = path;
    j["holds"] = {"surfels"};
    j["surfels"] = cloud->size();
    j["reference_mean_spacing"] = cloud->referenceMeanSpacing;
    fmt::print("{}\n", j.dump(2));
    return;
  }
  fmt::print("{}: surfel cloud (mirage surfels), {} surfels in progressive order\n", path, grouped(cloud->size()));
  fmt::print("  box {}  reference spacing mean {:.4g} median {:.4g} over the first {}\n", boundsText(cloud->box),
             cloud->referenceMeanSpacing, cloud->referenceMedianSpacing, cloud->referenceCount);
  fmt::print("  (render it with --surfels)\n");
}

} // namespace

void infoFile(const std::string& path, bool json, const std::string& materials) {
  if (!materials.empty() && (path.ends_with(".mrg") || (path.ends_with(".ply") && surfels::isSurfelPly(path))))
    return fail(path + ": --materials applies to scene files (.gltf .glb .obj .ply) and gen: scenes");
  if (path.ends_with(".mrg")) return infoMrg(path, json);
  if (path.ends_with(".ply") && surfels::isSurfelPly(path)) return infoSurfelPly(path, json);
  shading::MaterialFile file;
  if (!materials.empty()) { // read first: a bad material file costs no import
    auto loaded = shading::loadMaterialFile(materials);
    if (!loaded) return fail(loaded.error());
    file = std::move(*loaded);
  }
  io::ImportOptions options;
  options.allowPointClouds = true; // a scan without faces is described, not rejected (surfels reads it)
  auto scene = loadSceneArgument(path, options);
  if (!scene) return fail(scene.error());
  if (!materials.empty())
    if (auto st = shading::applyMaterials(*scene, file); !st) return fail(st.error());
  const Scene& s = *scene;
  Bounds b = s.worldBounds();
  size_t vertices = 0;
  for (const Mesh& m : s.meshes) vertices += m.vertexCount();
  size_t blend = 0, mask = 0;
  for (const Material& m : s.materials)
    blend += m.alphaMode == AlphaMode::Blend, mask += m.alphaMode == AlphaMode::Mask;
  bool points = surfels::isPointCloud(s);
  if (json) {
    nlohmann::json j = {{"file", path},
                        {"holds", {points ? "point cloud" : "scene"}},
                        {"meshes", s.meshes.size()},
                        {"instances", s.instances.size()},
                        {"triangles", s.meshTriangleCount()},
                        {"instanced_triangles", s.instancedTriangleCount()},
                        {"vertices", vertices},
                        {"materials", s.materials.size()},
                        {"materials_mask", mask},
                        {"materials_blend", blend},
                        {"textures", s.textures.size()},
                        {"lights", s.lights.size()}};
    j.update(boundsJson(b));
    if (!materials.empty()) j["material_list"] = materialList(s, path, false);
    fmt::print("{}\n", j.dump(2));
    return;
  }
  if (points) {
    fmt::print("{}: point cloud, {} points, no faces (sample it with mirage surfels)\n", path, grouped(vertices));
    fmt::print("  bounds {}\n", boundsText(b));
    return;
  }
  fmt::print("{}\n", path);
  fmt::print("  meshes {}  instances {}  triangles {} ({} instanced)  vertices {}\n", s.meshes.size(),
             s.instances.size(), s.meshTriangleCount(), s.instancedTriangleCount(), vertices);
  fmt::print("  materials {} ({} mask, {} blend)  textures {}\n", s.materials.size(), mask, blend, s.textures.size());
  if (!s.lights.empty()) fmt::print("  point lights {} (the file's and the material file's)\n", s.lights.size());
  fmt::print("  bounds {}\n", boundsText(b));
  if (materials.empty()) return;
  printMaterialList(materialList(s, path, false));
}

} // namespace mirage::cli
