// mirage pvs through the built binary (mirage::test::mirageBinary()): bad inputs give one line on
// stderr, exit 2 and no output file; a good run writes a .mrg whose PVS loads back.
#include <cstdlib>
#include <fstream>

#include <gtest/gtest.h>

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
