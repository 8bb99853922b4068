// `mirage surfels` end to end: a small run writes a readable PLY and .mrg; bad input (empty mesh,
// zero count, resolution above the device's limit, wrong extension) exits 2 with one line on stderr
// and writes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include <nlohmann/json.hpp>

#include "mirage/asset/container.h"
#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

namespace {

struct CliRun {
  int code = -1;
  std::string err;
};

// timeoutSeconds > 0: killed after that long (exit 124), so a hang fails the test instead of stalling it.
CliRun runMirage(const std::string& args, const std::filesystem::path& dir, int timeoutSeconds = 0) {
  std::string bin = mirage::test::mirageBinary();
  std::string errFile = (dir / "stderr.txt").string();
  std::string cmd = (timeoutSeconds > 0 ? "timeout " + std::to_string(timeoutSeconds) + " " : std::string()) + bin +
                    " " + args + " > /dev/null 2> " + errFile;
  int status = std::system(cmd.c_str());
  CliRun r;
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::ifstream f(errFile);
  std::stringstream s;
  s << f.rdbuf();
  r.err = s.str();
  return r;
}

} // namespace

TEST(SurfelCli, WritesPlyAndMrg) {
  ASSERT_TRUE(std::filesystem::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  auto dir = mirage::test::tempDir("surfels_cli");
  std::string ply = (dir / "blob.ply").string(), mrg = (dir / "blob.mrg").string();
  CliRun a = runMirage("surfels gen:blob:4 -o " + ply + " --count 300 --resolution 32 --views 6", dir);
  ASSERT_EQ(a.code, 0) << a.err;
  auto cloud = mirage::surfels::readSurfelPly(ply);
  ASSERT_TRUE(cloud.ok()) << cloud.error().message;
  EXPECT_EQ(cloud->size(), 300u);
  CliRun b = runMirage("surfels gen:blob:4 -o " + mrg + " --count 300 --resolution 32 --views 6", dir);
  ASSERT_EQ(b.code, 0) << b.err;
  auto fromMrg = mirage::surfels::readSurfelMrg(mrg);
  ASSERT_TRUE(fromMrg.ok()) << fromMrg.error().message;
  EXPECT_EQ(fromMrg->radii, cloud->radii); // same settings, same result
  // Smaller SURF blocks: the same cloud, and `info` describes the blocks (300 = 256 + 44 surfels).
  std::string small = (dir / "small.mrg").string();
  CliRun c = runMirage(
      "surfels gen:blob:4 -o " + small + " --count 300 --resolution 32 --views 6 --surfel-blocks 256:256", dir);
  ASSERT_EQ(c.code, 0) << c.err;
  auto fromSmall = mirage::surfels::readSurfelMrg(small);
  ASSERT_TRUE(fromSmall.ok()) << fromSmall.error().message;
  EXPECT_EQ(fromSmall->radii, cloud->radii);
  std::string json = (dir / "info.json").string();
  ASSERT_EQ(std::system((mirage::test::mirageBinary() + " info " + small + " --json > " + json).c_str()), 0);
  std::ifstream f(json);
  nlohmann::json info = nlohmann::json::parse(f);
  const nlohmann::json& blocks = info["surfels"]["clouds"][0];
  EXPECT_EQ(blocks["layout"], "blocked");
  EXPECT_EQ(blocks["blocks"], 2);
  EXPECT_EQ(blocks["first_block_surfels"], 256);
  EXPECT_EQ(info["chunks"][0]["blocked"], 1);
}

TEST(SurfelCli, PerMeshChunksAndPointClouds) {
  auto dir = mirage::test::tempDir("surfels_cli_more");
  // gen:city has several meshes: one SURF chunk each, in mesh order, each with its own surfels.
  std::string mrg = (dir / "city.mrg").string();
  CliRun a = runMirage("surfels gen:city:2 -o " + mrg + " --count 20 --resolution 16 --views 3 --per-mesh", dir);
  ASSERT_EQ(a.code, 0) << a.err;
  auto all = mirage::surfels::readSurfelMrgAll(mrg);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_GT(all->size(), 1u);
  for (size_t i = 0; i < all->size(); ++i) {
    EXPECT_GT((*all)[i].cloud.size(), 0u);
    if (i > 0) {
      EXPECT_GT((*all)[i].mesh, (*all)[i - 1].mesh);
    }
  }
  EXPECT_EQ(runMirage("surfels gen:city:2 -o " + (dir / "city.ply").string() + " --per-mesh", dir).code, 2);

  // A point cloud PLY (vertices with normals, no faces) in, surfels out.
  std::string cloud = (dir / "cloud.ply").string();
  {
    std::ofstream f(cloud, std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 2000\nproperty float x\nproperty float y\n"
         "property float z\nproperty float nx\nproperty float ny\nproperty float nz\nend_header\n";
    for (int i = 0; i < 2000; ++i) { // a 40 x 50 grid on the plane z = 0
      float v[6] = {float(i % 40) * 0.1f, float(i / 40) * 0.1f, 0.0f, 0.0f, 0.0f, 1.0f};
      f.write(reinterpret_cast<const char*>(v), sizeof(v));
    }
  }
  std::string out = (dir / "cloud_surfels.ply").string();
  CliRun b = runMirage("surfels " + cloud + " -o " + out + " --count 200", dir);
  ASSERT_EQ(b.code, 0) << b.err;
  auto surfels = mirage::surfels::readSurfelPly(out);
  ASSERT_TRUE(surfels.ok()) << surfels.error().message;
  EXPECT_EQ(surfels->size(), 200u);
}

TEST(SurfelCli, BadInputsExit2WithOneLineAndWriteNothing) {
  ASSERT_TRUE(std::filesystem::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  auto dir = mirage::test::tempDir("surfels_cli_bad");
  std::string empty = (dir / "empty.obj").string();
  std::ofstream(empty) << "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  std::string out = (dir / "out.ply").string();
  for (std::string args :
       {"surfels " + empty + " -o " + out, "surfels gen:blob:3 -o " + out + " --count 0",
        "surfels gen:blob:3 -o " + out + " --resolution 1000000", "surfels gen:blob:3 -o " + (dir / "out.txt").string(),
        "surfels gen:blob:3 -o " + out + " --disc-raster depth",
        "surfels gen:blob:3 -o " + out + " --disc-raster compute,", // empty choice
        "surfels gen:blob:3 -o " + (dir / "out.mrg").string() + " --per-mesh --disc-raster all",
        "surfels gen:blob:3 -o " + out + " --surfel-blocks 1000:16384", // not a power of two
        "surfels gen:blob:3 -o " + out + " --surfel-blocks 4096:1024",  // first above max
        "surfels gen:blob:3 -o " + out + " --surfel-blocks 1024",
        std::string("bench surfels-sampler gen:blob:3 --disc-raster quad")}) {
    CliRun r = runMirage(args, dir);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("mirage: error: ", 0), 0u) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
  }
}

// --disc-raster: every splatter writes the same surfels (the same order, so the same file); `all`
// times them side by side and writes compute's; the bench prints one JSON row per splatter.
TEST(SurfelCli, DiscRasterChoicesWriteTheSameSurfels) {
  auto dir = mirage::test::tempDir("surfels_cli_disc");
  std::string base = "surfels gen:blob:4 --count 300 --resolution 32 --views 6 -o ";
  auto read = [&](const std::string& name) {
    std::ifstream f(dir / name, std::ios::binary);
    std::stringstream s;
    s << f.rdbuf();
    return s.str();
  };
  CliRun compute = runMirage(base + (dir / "compute.ply").string() + " --disc-raster compute", dir);
  ASSERT_EQ(compute.code, 0) << compute.err;
  std::string expected = read("compute.ply");
  ASSERT_FALSE(expected.empty());
  for (std::string raster : {"mesh", "geometry", "mesh-depth", "all", "geometry,mesh"}) {
    std::string name = "out_" + raster + ".ply";
    CliRun r = runMirage(base + (dir / name).string() + " --disc-raster " + raster, dir);
    if (r.code == 2 && r.err.find("does not have") != std::string::npos) continue; // unsupported on this device
    ASSERT_EQ(r.code, 0) << raster << ": " << r.err;
    EXPECT_TRUE(read(name) == expected) << raster;
  }
  std::string json = (dir / "bench.json").string();
  std::string cmd = mirage::test::mirageBinary() +
                    " bench surfels-sampler gen:blob:4 --count 300 --resolution 32 --views 6 --repeat 1 --json > " +
                    json;
  ASSERT_EQ(std::system(cmd.c_str()), 0);
  std::string text = read("bench.json");
  EXPECT_NE(text.find("\"disc_raster\": \"compute\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"disc_raster\": \"mesh\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"disc_raster\": \"geometry\""), std::string::npos) << text;
  EXPECT_NE(text.find("\"disc_raster\": \"mesh-depth\""), std::string::npos) << text;
  EXPECT_EQ(text.find("\"same_order\": false"), std::string::npos) << text;
}

// Synthetic scans (`gen points`) and the GPU point path (`--points gpu`) end to end, the bench
// that runs both paths, and the point path's bad inputs.
TEST(SurfelCli, GenPointsAndTheGpuPointPath) {
  auto dir = mirage::test::tempDir("surfels_cli_points");
  std::string scan = (dir / "scan.ply").string(), again = (dir / "scan2.ply").string();
  ASSERT_EQ(runMirage("gen points --mesh gen:blob:3 --points 20000 --seed 3 -o " + scan, dir).code, 0);
  ASSERT_EQ(runMirage("gen points --mesh gen:blob:3 --points 20000 --seed 3 -o " + again, dir).code, 0);
  auto bytes = [](const std::string& path) {
    std::ifstream f(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(f), {});
  };
  EXPECT_EQ(bytes(scan), bytes(again)); // deterministic per seed

  std::string gpu = (dir / "gpu.ply").string(), gpu2 = (dir / "gpu2.ply").string(), cpu = (dir / "cpu.ply").string();
  std::string common = " --count 300 --resolution 48 --views 6";
  CliRun a = runMirage("surfels " + scan + " -o " + gpu + common + " --points gpu", dir);
  ASSERT_EQ(a.code, 0) << a.err;
  ASSERT_EQ(runMirage("surfels " + scan + " -o " + gpu2 + common + " --points gpu", dir).code, 0);
  EXPECT_EQ(bytes(gpu), bytes(gpu2)); // the GPU path is deterministic too
  ASSERT_EQ(runMirage("surfels " + scan + " -o " + cpu + common + " --points cpu", dir).code, 0);
  for (const std::string& path : {gpu, cpu}) {
    auto cloud = mirage::surfels::readSurfelPly(path);
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    EXPECT_EQ(cloud->size(), 300u) << path;
  }
  EXPECT_EQ(runMirage("bench surfels-points " + scan + common, dir).code, 0);

  // A scan without normals: both paths estimate them (PCA of the neighbours).
  std::string bare = (dir / "bare.ply").string();
  {
    std::ofstream f(bare, std::ios::binary);
    f << "ply\nformat binary_little_endian 1.0\nelement vertex 400\nproperty float x\nproperty float y\n"
         "property float z\nend_header\n";
    for (int i = 0; i < 400; ++i) {
      float v[3] = {float(i % 20) * 0.1f, float(i / 20) * 0.1f, 0.0f};
      f.write(reinterpret_cast<const char*>(v), sizeof(v));
    }
  }
  std::string out = (dir / "out.ply").string();
  for (const char* path : {"cpu", "gpu"}) {
    CliRun r =
        runMirage("surfels " + bare + " -o " + out + " --count 50 --resolution 32 --views 4 --points " + path, dir);
    EXPECT_EQ(r.code, 0) << path << ": " << r.err;
    auto cloud = mirage::surfels::readSurfelPly(out);
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    for (const auto& s : cloud->surfels) // a plane z = 0: estimated normals are ±z
      EXPECT_GT(std::abs(mirage::surfels::surfelNormal(s).z), 0.999f) << path;
    std::filesystem::remove(out);
  }
  for (std::string args : {"surfels " + scan + " -o " + out + " --points fast",
                           "surfels " + bare + " -o " + out + " --points gpu --layers 2",
                           "gen points --points 100 -o " + out, "gen points --mesh gen:blob:2 -o " + out,
                           "gen points --mesh gen:blob:2 --points 100 -o " + (dir / "out.glb").string(),
                           std::string("bench surfels-points gen:blob:2")}) {
    CliRun r = runMirage(args, dir);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
  }
}

// One non-finite coordinate in a point cloud: both point paths exit 2 at once with one line naming
// the file and the point (the GPU sampler used to resubmit rounds forever; the CPU path wrote
// surfels from it). `timeout` turns a hang into a failure instead of a stuck test.
TEST(SurfelCli, NonFinitePointCloudsExit2Quickly) {
  auto dir = mirage::test::tempDir("surfels_cli_nan");
  std::string out = (dir / "s.ply").string();
  for (const char* bad : {"nan", "inf", "-inf"}) {
    std::string scan = (dir / (std::string("pts_") + (bad[0] == '-' ? "minf" : bad) + ".ply")).string();
    {
      std::ofstream f(scan);
      f << "ply\nformat ascii 1.0\nelement vertex 300\nproperty float x\nproperty float y\nproperty float z\n"
           "end_header\n";
      for (int i = 0; i < 300; ++i) {
        float a = float(i) * 2.39996f, z = 1.0f - 2.0f * (float(i) + 0.5f) / 300.0f, r = std::sqrt(1.0f - z * z);
        if (i == 137)
          f << r * std::cos(a) << " " << bad << " " << z << "\n";
        else
          f << r * std::cos(a) << " " << r * std::sin(a) << " " << z << "\n";
      }
    }
    for (const char* path : {"gpu", "cpu"}) {
      CliRun r = runMirage("surfels " + scan + " -o " + out + " --count 200 --resolution 64 --views 4 --points " + path,
                           dir, 60);
      EXPECT_EQ(r.code, 2) << bad << " " << path << ": " << r.err;
      EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
      EXPECT_NE(r.err.find(scan), std::string::npos) << r.err;
      EXPECT_NE(r.err.find("137"), std::string::npos) << r.err; // the point, as the file numbers it
      EXPECT_FALSE(std::filesystem::exists(out)) << bad << " " << path;
    }
  }
}

// The fuzzing reproducers (points with NaN and infinity; a mesh with a NaN vertex): exit 2, no hang.
TEST(SurfelCli, FuzzedNonFiniteInputsExit2) {
  MIRAGE_REQUIRE_DATA(folder, "fuzz-regressions");
  auto dir = mirage::test::tempDir("surfels_cli_fuzz_nan");
  std::string out = (dir / "s.ply").string();
  for (const char* name : {"pts_nan.ply", "pts_inf.ply", "blob_nan.ply"}) {
    std::string input = (folder / name).string();
    CliRun r = runMirage(
        "surfels " + input + " -o " + out + " --count 200 --resolution 64 --views 4 --quiet --points gpu", dir, 60);
    EXPECT_EQ(r.code, 2) << name << ": " << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_NE(r.err.find(name), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << name;
  }
}

// --append adds SURF chunks to a baked asset: every other chunk keeps its stored bytes (it was
// recompressed at a lower zstd level, 9 % larger), and appending again replaces the SURF chunks.
TEST(SurfelCli, AppendKeepsExistingChunksByteIdentical) {
  auto dir = mirage::test::tempDir("surfels_cli_append");
  std::string mrg = (dir / "blob.mrg").string();
  ASSERT_EQ(runMirage("build gen:blob:4 -o " + mrg + " --quiet", dir).code, 0);
  auto storedChunks = [&] {
    std::vector<std::pair<mirage::asset::ChunkInfo, std::vector<uint8_t>>> out;
    auto reader = mirage::asset::AssetReader::open(mrg);
    EXPECT_TRUE(reader.ok()) << reader.error().message;
    if (!reader) return out;
    for (size_t i = 0; i < reader->chunks().size(); ++i)
      if (reader->chunks()[i].type != mirage::asset::chunk::Surfels)
        out.push_back({reader->chunks()[i], *reader->readStoredChunk(i)});
    return out;
  };
  auto before = storedChunks();
  ASSERT_GE(before.size(), 3u); // SCEN, CDAG, TMAP, META
  std::string append = "surfels gen:blob:4 -o " + mrg + " --count 50 --resolution 16 --views 3 --per-mesh --append";
  for (int pass = 0; pass < 2; ++pass) {
    CliRun r = runMirage(append, dir);
    ASSERT_EQ(r.code, 0) << r.err;
    auto after = storedChunks();
    ASSERT_EQ(after.size(), before.size());
    for (size_t i = 0; i < before.size(); ++i) {
      std::string what = before[i].first.type.str() + " chunk " + std::to_string(i) + " pass " + std::to_string(pass);
      EXPECT_EQ(after[i].first.type, before[i].first.type) << what;
      EXPECT_EQ(after[i].first.zstdLevel, before[i].first.zstdLevel) << what;
      EXPECT_EQ(after[i].first.rawHash, before[i].first.rawHash) << what;
      EXPECT_TRUE(after[i].second == before[i].second) << what << ": stored bytes changed";
    }
    auto clouds = mirage::surfels::readSurfelMrgAll(mrg);
    ASSERT_TRUE(clouds.ok()) << clouds.error().message;
    EXPECT_EQ(clouds->size(), 1u);
  }
}
