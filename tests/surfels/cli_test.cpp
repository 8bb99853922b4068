// `mirage surfels` end to end: a small run writes a readable PLY and .mrg; bad input (empty mesh,
// zero count, resolution above the device's limit, wrong extension) exits 2 with one line on stderr
// and writes nothing.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <sys/wait.h>

#include "mirage/surfels/surfel_io.h"
#include "test_support.h"

namespace {

struct CliRun {
  int code = -1;
  std::string err;
};

CliRun runMirage(const std::string& args, const std::filesystem::path& dir) {
  std::string bin = mirage::test::mirageBinary();
  std::string errFile = (dir / "stderr.txt").string();
  std::string cmd = bin + " " + args + " > /dev/null 2> " + errFile;
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
}

TEST(SurfelCli, BadInputsExit2WithOneLineAndWriteNothing) {
  ASSERT_TRUE(std::filesystem::exists(mirage::test::mirageBinary())) << mirage::test::mirageBinary();
  auto dir = mirage::test::tempDir("surfels_cli_bad");
  std::string empty = (dir / "empty.obj").string();
  std::ofstream(empty) << "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
  std::string out = (dir / "out.ply").string();
  for (std::string args : {"surfels " + empty + " -o " + out, "surfels gen:blob:3 -o " + out + " --count 0",
                           "surfels gen:blob:3 -o " + out + " --resolution 1000000",
                           "surfels gen:blob:3 -o " + (dir / "out.txt").string()}) {
    CliRun r = runMirage(args, dir);
    EXPECT_EQ(r.code, 2) << args;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << args << ": " << r.err;
    EXPECT_EQ(r.err.rfind("mirage: error: ", 0), 0u) << r.err;
    EXPECT_FALSE(std::filesystem::exists(out)) << args;
  }
}
