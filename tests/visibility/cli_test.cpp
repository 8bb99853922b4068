// mirage pvs through the built binary (mirage::test::mirageBinary()): bad inputs give one line on
// stderr, exit 2 and no output file; a good run writes a .mrg whose PVS loads back.
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "mirage/visibility/pvs_storage.h"
#include "test_support.h"

namespace fs = std::filesystem;

namespace {

struct CliRun {
  int code = -1;
  std::string err;
};

CliRun runMirage(const std::string& args, const fs::path& dir) {
  std::string exe = mirage::test::mirageBinary();
  fs::path errFile = dir / "stderr.txt";
  int status =
      std::system((exe + " " + args + " > " + (dir / "stdout.txt").string() + " 2> " + errFile.string()).c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream in(errFile);
  r.err.assign(std::istreambuf_iterator<char>(in), {});
  return r;
}

void write(const fs::path& p, const std::string& text) { std::ofstream(p) << text; }

} // namespace

TEST(PvsCli, BadInputsFailCleanly) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_cli");
  write(dir / "broken.json", "{\"cells\": [");
  write(dir / "flat.json", R"({"cells": [{"type": "box", "position": [0,0,0], "size": [2,0,2]}]})");
  write(dir / "ok.json", R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]}]})");
  write(dir / "gvs.json", R"({"random_rays": -4})");
  fs::path out = dir / "out.mrg";
  const std::string cases[] = {
      "pvs gen:city:1 --cells " + (dir / "broken.json").string() + " -o " + out.string(),
      "pvs gen:city:1 --cells " + (dir / "flat.json").string() + " -o " + out.string(),
      "pvs gen:city:1 --cells " + (dir / "missing.json").string() + " -o " + out.string(),
      "pvs gen:city:1 --cell-grid 2x2 -o " + out.string(),
      "pvs gen:city:1 -o " + out.string(),
      "pvs gen:city:1 --cells " + (dir / "ok.json").string() + " -o " + (dir / "out.png").string(),
      "pvs gen:nothing --cells " + (dir / "ok.json").string() + " -o " + out.string(),
      "pvs gen:city:1 --cells " + (dir / "ok.json").string() + " --config " + (dir / "gvs.json").string() + " -o " +
          out.string(),
      "pvs gen:city:1 --cells " + (dir / "ok.json").string() + " --backend optix -o " + out.string(),
      "pvs gen:city:1 --cells " + (dir / "ok.json").string() + " --backend vulkan --device nosuchgpu -o " +
          out.string(),
      "bench rays gen:city:1 --backend optix",
      "pvs gen:city:1 --cells " + (dir / "ok.json").string() + " --backend compute-bvh16 -o " + out.string(),
  };
  for (const std::string& args : cases) {
    CliRun r = runMirage(args, dir);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("mirage: error: ", 0), 0u) << r.err;
    EXPECT_FALSE(fs::exists(out)) << args;
  }
}

TEST(PvsCli, BakesAndLoadsBack) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_cli_ok");
  write(dir / "ok.json", R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]},
                                       {"type": "rect", "position": [4,1.7,-38], "size": [4,4]}]})");
  fs::path out = dir / "out.mrg";
  CliRun r = runMirage("pvs gen:city:1 --cells " + (dir / "ok.json").string() + " -o " + out.string() +
                           " --rays 5000 --abs-edge 8 --json",
                       dir);
  ASSERT_EQ(r.code, 0) << r.err;
  auto pvs = mirage::vis::loadPvs(out.string());
  ASSERT_TRUE(pvs.ok()) << pvs.error().message;
  ASSERT_EQ(pvs->cells.size(), 2u);
  EXPECT_GT(pvs->triangles[0].size(), 0u);
  EXPECT_EQ(pvs->cells[1].shape, mirage::vis::CellShape::Rect);
}

// --backend compute bakes what Embree bakes (within sampling noise: tie-breaking sends the samplers
// down different paths), and bench rays times every traversal on the same rays.
// Cells in flight: three cells on three lanes of the compute backend, each on its own thread, write
// the bytes one lane writes (the lane count never reaches the file).
TEST(PvsCli, CellsInFlightWriteTheSameBytes) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_cli_lanes");
  std::string bytes[2];
  for (int lanes : {1, 3}) {
    fs::path out = dir / ("lanes" + std::to_string(lanes) + ".mrg");
    CliRun r = runMirage("pvs gen:city:1 --cell-grid 1x1x3 --cell-region -2,0.7,-12,2,2.7,0 --rays 20000 --budget "
                         "150000 --backend compute --json --cells-in-flight " +
                             std::to_string(lanes) + " -o " + out.string(),
                         dir);
    ASSERT_EQ(r.code, 0) << r.err;
    std::ifstream json(dir / "stdout.txt");
    auto j = nlohmann::json::parse(std::string((std::istreambuf_iterator<char>(json)), {}));
    std::vector<uint32_t> units = j["per_rank"][0]["units"].get<std::vector<uint32_t>>();
    std::sort(units.begin(), units.end());
    EXPECT_EQ(units, (std::vector<uint32_t>{0, 1, 2}));
    std::ifstream in(out, std::ios::binary);
    bytes[lanes == 3] = std::string((std::istreambuf_iterator<char>(in)), {});
  }
  EXPECT_FALSE(bytes[0].empty());
  EXPECT_TRUE(bytes[0] == bytes[1]) << "three lanes wrote other bytes than one";
  EXPECT_NE(runMirage("pvs gen:city:1 --cell-grid 1x1x1 --cells-in-flight 17 -o " + (dir / "x.mrg").string(), dir).code,
            0);
}

TEST(PvsCli, ComputeTraversalBakesLikeEmbreeAndBenches) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_cli_compute");
  write(dir / "ok.json", R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]}]})");
  // Embree; compute with border and reverse rays made on the device (the default) and on the host.
  std::vector<uint32_t> sets[3];
  const char* backends[3] = {"embree", "compute", "compute --host-exploration"};
  for (int b = 0; b < 3; ++b) {
    fs::path out = dir / ("bake" + std::to_string(b) + ".mrg");
    CliRun r = runMirage("pvs gen:city:1 --cells " + (dir / "ok.json").string() + " -o " + out.string() +
                             " --rays 20000 --abs-edge 10 --seed 3 --json --backend " + backends[b],
                         dir);
    ASSERT_EQ(r.code, 0) << r.err;
    std::ifstream in(dir / "stdout.txt");
    auto json = nlohmann::json::parse(std::string((std::istreambuf_iterator<char>(in)), {}));
    EXPECT_EQ(json["explore_rays_generated_on_device"].get<bool>(), b == 1) << backends[b];
    auto pvs = mirage::vis::loadPvs(out.string());
    ASSERT_TRUE(pvs.ok()) << pvs.error().message;
    sets[b] = pvs->triangles[0];
  }
  for (int b = 1; b < 3; ++b) {
    std::vector<uint32_t> both;
    std::set_intersection(sets[0].begin(), sets[0].end(), sets[b].begin(), sets[b].end(), std::back_inserter(both));
    std::printf("city:1 cell: Embree %zu triangles, %s %zu, shared %zu\n", sets[0].size(), backends[b], sets[b].size(),
                both.size());
    EXPECT_NEAR(double(sets[b].size()), double(sets[0].size()), 0.1 * double(sets[0].size()));
    EXPECT_GE(double(both.size()), 0.9 * double(sets[0].size()));
  }

  CliRun r = runMirage("bench rays gen:city:1 --rays 20000 --repeat 1 --backend all --json --work 20000", dir);
  ASSERT_EQ(r.code, 0) << r.err;
  std::ifstream in(dir / "stdout.txt");
  std::string text((std::istreambuf_iterator<char>(in)), {});
  auto json = nlohmann::json::parse(text);
  size_t compute = 0, staged = 0;
  for (const auto& res : json["results"]) {
    const std::string backend = res["backend"].get<std::string>();
    if (backend.find(" staged") != std::string::npos) { // the same rays from device-local copies
      ++staged;
      EXPECT_EQ(res["same_hits_as_unstaged"].get<double>(), 1.0) << res.dump();
      EXPECT_GT(res["copy_ms"].get<double>(), 0.0);
      EXPECT_EQ(res["copy_bytes"].get<double>(), 20000.0 * (24 + 16)); // compact rays in, hits out
      continue;
    }
    if (!res.contains("traversal") || backend.find("generated") != std::string::npos ||
        backend.find(" 32B rays") != std::string::npos)
      continue;
    EXPECT_GE(res["same_hit_as_embree"].get<double>(), 0.99) << res.dump();
    EXPECT_GT(res["gpu_ms"].get<double>(), 0.0);
    const std::string traversal = res["traversal"].get<std::string>();
    if (traversal.rfind("compute", 0) == 0) {
      ++compute;
      EXPECT_EQ(res["backend"].get<std::string>(), "vulkan-" + traversal); // the --backend value to bake with
    }
  }
  // 4-wide, 4-wide persistent, 2-wide, 2-wide persistent, 2-wide shared-memory stack, 8-wide, 8-wide
  // persistent, 8-wide with triangle postponing
  EXPECT_EQ(compute, 8u);
  EXPECT_EQ(staged, compute);
  // The CPU replica counts the same work on host-made and generated rays (the same distribution;
  // 20 k rays: within a few percent), and fewer nodes per ray on the 8-wide tree.
  ASSERT_EQ(json["work"].size(), 4u);
  std::map<std::string, double> nodes;
  for (const auto& w : json["work"])
    nodes[std::to_string(w["bvh_width"].get<int>()) + w["rays"].get<std::string>()] = w["nodes_per_ray"].get<double>();
  EXPECT_NEAR(nodes["4host"], nodes["4generated"], 0.05 * nodes["4host"]);
  EXPECT_NEAR(nodes["8host"], nodes["8generated"], 0.05 * nodes["8host"]);
  EXPECT_LT(nodes["8host"], nodes["4host"]);
  EXPECT_GT(nodes["8host"], 1.0);
  EXPECT_GE(json["speedups"].size(), 1u);
}

// A view cell far outside the scene (1e30 from a city) aborted inside Embree; now the cells file is
// rejected with one line naming it and the cell, exit 2, no output.
TEST(PvsCli, FarCellsAreRejectedNamingTheCell) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  MIRAGE_REQUIRE_DATA(far, "fuzz-regressions/cells_far.json");
  fs::path dir = mirage::test::tempDir("pvs_cli_far");
  write(dir / "far2.json", R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]},
                                         {"type": "box", "position": [0,1e20,0], "size": [4,2,4]}]})");
  write(dir / "huge.json", R"({"cells": [{"type": "box", "position": [0,0,0], "size": [1e25,1e25,1e25]}]})");
  fs::path out = dir / "p.mrg";
  struct Case {
    std::string args, file, cell;
  } cases[] = {
      {"pvs gen:city:1 --cells " + far.string() + " -o " + out.string() + " --rays 10000 --budget 100000", far.string(),
       "cell 0"},
      {"pvs-eval gen:city:1 --cells " + far.string() + " --rays 10000 --budget 100000 --size 8", far.string(),
       "cell 0"},
      {"pvs gen:city:1 --cells " + (dir / "far2.json").string() + " -o " + out.string(), (dir / "far2.json").string(),
       "cell 1"},
      {"pvs gen:city:1 --cells " + (dir / "huge.json").string() + " -o " + out.string(), (dir / "huge.json").string(),
       "cell 0"},
      {"pvs gen:city:1 --cell-grid 2x1x1 --cell-region -1e25,0,-1e25,1e25,2,1e25 -o " + out.string(), "--cell-region",
       "cell 0"},
  };
  for (const Case& c : cases) {
    CliRun r = runMirage(c.args, dir);
    EXPECT_EQ(r.code, 2) << c.args << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << c.args << ": " << r.err;
    EXPECT_NE(r.err.find(c.file + ": " + c.cell + ": "), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(out)) << c.args;
  }
}

// Progress: plain lines per cell with --progress (stderr), nothing at all with --quiet.
TEST(PvsCli, ProgressLinesAndQuiet) {
  ASSERT_TRUE(fs::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  fs::path dir = mirage::test::tempDir("pvs_cli_progress");
  write(dir / "two.json", R"({"cells": [{"type": "box", "position": [0,1.7,-38], "size": [4,2,4]},
                                        {"type": "box", "position": [4,1.7,-38], "size": [4,2,4]}]})");
  const std::string base = "pvs gen:city:1 --cells " + (dir / "two.json").string() + " --rays 5000 --budget 40000";
  CliRun r = runMirage(base + " --progress -o " + (dir / "a.mrg").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  // One task per cell through the shared reporter: rays of the budget, then the cell's result
  // (ETA formatting is core's, tested in progress_test: this bake is over within the throttle).
  EXPECT_NE(r.err.find("cell 1/2 GVS++: 0/40000 ("), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cell 2/2 GVS++: done "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find(" triangles, "), std::string::npos) << r.err;
  r = runMirage(base + " --quiet -o " + (dir / "b.mrg").string(), dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_TRUE(r.err.empty()) << r.err;
  std::ifstream out(dir / "stdout.txt");
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(out), {}), "");
  r = runMirage("pvs-eval gen:city:1 --cells " + (dir / "two.json").string() +
                    " --rays 5000 --budget 20000 --size 8 --viewpoints 1 --progress",
                dir);
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.err.find("cell 2/2 RAND: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("cell 2/2 evaluation 3: done 54/54"), std::string::npos) << r.err;
}
