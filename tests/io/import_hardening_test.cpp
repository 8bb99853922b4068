// Hostile and broken inputs: each gets one Error line naming the input file, never a crash, a hang, raw input bytes
// in the message or a silently incomplete scene. Small files are generated; the fuzz reproducers run when present.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>

#include <sys/stat.h>

#include "mirage/core/input_text.h"
#include "mirage/io/image_io.h"
#include "mirage/io/import.h"
#include "import_test_util.h"
#include "support/test_support.h"

using namespace mirage;

namespace {

using test::writeFile;

// The import failed with one printable line that begins with the file's name and holds `phrase`.
void expectCleanError(const Result<Scene>& r, const std::filesystem::path& file, const std::string& phrase) {
  ASSERT_FALSE(r.ok()) << "expected an error containing '" << phrase << "'";
  const std::string& msg = r.error().message;
  EXPECT_EQ(msg.rfind(file.string() + ": ", 0), 0u) << msg;
  EXPECT_NE(msg.find(phrase), std::string::npos) << msg;
  for (char c : msg) EXPECT_TRUE(c >= 0x20 && c < 0x7f) << "raw byte " << int(c) << " in: " << msg;
}

void put32(std::string& s, uint32_t v) { s.append(reinterpret_cast<const char*>(&v), 4); }

// A GLB of `json` and an optional BIN chunk (padded to 4 bytes as the format requires).
std::string glb(std::string json, std::string bin = {}) {
  json.resize((json.size() + 3) / 4 * 4, ' ');
  bin.resize((bin.size() + 3) / 4 * 4, '\0');
  std::string out = "glTF";
  put32(out, 2);
  put32(out, uint32_t(12 + 8 + json.size() + (bin.empty() ? 0 : 8 + bin.size())));
  put32(out, uint32_t(json.size()));
  put32(out, 0x4E4F534A);
  out += json;
  if (!bin.empty()) {
    put32(out, uint32_t(bin.size()));
    put32(out, 0x004E4942);
    out += bin;
  }
  return out;
}

// One triangle in tri.bin beside the .gltf; `extra` is spliced into the top-level JSON object, `nodes` replaces the
// node list (node 0 draws the mesh).
std::filesystem::path triangleGltf(const std::filesystem::path& dir, const std::string& name,
                                   const std::string& extra = "", const std::string& nodes = R"([{"mesh":0}])",
                                   const std::string& sceneNodes = "[0]") {
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  writeFile(dir / "tri.bin", std::string(reinterpret_cast<const char*>(v), sizeof v));
  std::string json = R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":)" + sceneNodes + R"(}],"nodes":)" +
                     nodes +
                     R"(,"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],)"
                     R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3",)"
                     R"("min":[0,0,0],"max":[1,1,0]}],"bufferViews":[{"buffer":0,"byteLength":36}],)"
                     R"("buffers":[{"uri":"tri.bin","byteLength":36}])" +
                     extra + "}";
  return writeFile(dir / name, json);
}

// A GLB whose bufferView 0 is EXT_meshopt_compression data with the given parameters (checked before decoding, so
// the 16 compressed bytes need not be valid).
std::string meshoptGlb(const std::string& mode, int stride, int count, const std::string& filter = "NONE") {
  std::string ext = R"({"buffer":0,"byteLength":16,"byteStride":)" + std::to_string(stride) + R"(,"count":)" +
                    std::to_string(count) + R"(,"mode":")" + mode + R"(","filter":")" + filter + R"("})";
  std::string json = R"({"asset":{"version":"2.0"},"extensionsUsed":["EXT_meshopt_compression"],)"
                     R"("buffers":[{"byteLength":16},{"byteLength":4096,)"
                     R"("extensions":{"EXT_meshopt_compression":{"fallback":true}}}],)"
                     R"("bufferViews":[{"buffer":1,"byteLength":)" +
                     std::to_string(stride * count) + R"(,"extensions":{"EXT_meshopt_compression":)" + ext + "}}]}";
  return glb(json, std::string(16, '\0'));
}

} // namespace

TEST(InputText, EscapesControlBytesAndInvalidUtf8) {
  EXPECT_EQ(quoteInput("plain"), "'plain'");
  EXPECT_EQ(quoteInput(std::string("a\nb\x1b[2J\x7f", 8)), "'a\\x0ab\\x1b[2J\\x7f'");
  EXPECT_EQ(quoteInput("back\\slash"), "'back\\\\slash'");
  EXPECT_EQ(quoteInput("mod\xc3\xa8le"), "'mod\xc3\xa8le'"); // well-formed UTF-8 kept
  EXPECT_EQ(quoteInput("\xc3\x28 \xc0\xaf \xed\xa0\x80"),
            "'\\xc3( \\xc0\\xaf \\xed\\xa0\\x80'");  // invalid, overlong, surrogate
  EXPECT_EQ(quoteInput("\xc2\x85"), "'\\xc2\\x85'"); // C1 control (NEL)
  EXPECT_EQ(quoteInput(std::string(100, 'x'), 10), "'xxxxxxxxxx...'");
}

// A directory, a FIFO, a missing file: the same words from every importer and from the dispatcher, whatever the
// name's extension (or none).
TEST(ImportHardening, InputPathsHaveOneWording) {
  auto dir = test::tempDir("input_paths");
  for (const char* name : {"d.glb", "d.gltf", "d.obj", "d.ply", "scans"}) {
    std::filesystem::create_directory(dir / name);
    expectCleanError(io::importScene(dir / name), dir / name, "is a directory, not a regular file");
  }
  expectCleanError(io::importPly(dir / "d.ply"), dir / "d.ply", "is a directory, not a regular file");
  expectCleanError(io::importGltf(dir / "d.glb"), dir / "d.glb", "is a directory, not a regular file");
  expectCleanError(io::importObj(dir / "d.obj"), dir / "d.obj", "is a directory, not a regular file");
  ASSERT_EQ(::mkfifo((dir / "f.ply").c_str(), 0600), 0);
  expectCleanError(io::importScene(dir / "f.ply"), dir / "f.ply", "is a FIFO (named pipe), not a regular file");
  expectCleanError(io::importPly(dir / "f.ply"), dir / "f.ply", "is a FIFO (named pipe), not a regular file");
  expectCleanError(io::importScene(dir / "missing.ply"), dir / "missing.ply", "file not found");
  expectCleanError(io::importScene(dir / "missing"), dir / "missing", "file not found");
  // Image inputs (compare, reference images) use the same words.
  std::filesystem::create_directory(dir / "d.png");
  auto png = io::readPng(dir / "d.png");
  ASSERT_FALSE(png.ok());
  EXPECT_EQ(png.error().message, (dir / "d.png").string() + ": is a directory, not a regular file");
}

TEST(ImportHardening, EmptyAndTruncatedGlb) {
  auto dir = test::tempDir("empty_glb");
  auto empty = writeFile(dir / "empty.glb", "");
  expectCleanError(io::importScene(empty), empty, "empty file (0 bytes)");
  for (const char* name : {"empty.gltf", "empty.obj", "empty.ply"}) // one wording for every format
    expectCleanError(io::importScene(writeFile(dir / name, "")), dir / name, "empty file (0 bytes)");
  auto shortGlb = writeFile(dir / "short.glb", std::string("glTF\x02\0\0\0", 8));
  expectCleanError(io::importScene(shortGlb), shortGlb, "truncated GLB");
}

// F3-F5: the constraints the meshoptimizer decoders assert on are errors first.
TEST(ImportHardening, MeshoptConstraintsCheckedBeforeDecoding) {
  auto dir = test::tempDir("meshopt_constraints");
  struct Case {
    const char* name;
    std::string bytes;
    const char* phrase;
  } cases[] = {
      {"tri_count.glb", meshoptGlb("TRIANGLES", 4, 100), "mode TRIANGLES needs a count divisible by 3 (got 100)"},
      {"tri_stride.glb", meshoptGlb("TRIANGLES", 12, 3), "mode TRIANGLES needs byteStride 2 or 4 (got 12)"},
      {"idx_stride.glb", meshoptGlb("INDICES", 1, 3), "mode INDICES needs byteStride 2 or 4 (got 1)"},
      {"attr_stride.glb", meshoptGlb("ATTRIBUTES", 3, 1), "mode ATTRIBUTES needs a byteStride divisible by 4 (got 3)"},
      {"oct_stride.glb", meshoptGlb("ATTRIBUTES", 12, 1, "OCTAHEDRAL"), "filter OCTAHEDRAL needs byteStride 4 or 8"},
      {"quat_stride.glb", meshoptGlb("ATTRIBUTES", 4, 1, "QUATERNION"), "filter QUATERNION needs byteStride 8"},
      {"filter_mode.glb", meshoptGlb("TRIANGLES", 4, 3, "EXPONENTIAL"), "filter 'EXPONENTIAL' needs mode ATTRIBUTES"},
  };
  for (const Case& c : cases) {
    auto path = writeFile(dir / c.name, c.bytes);
    expectCleanError(io::importScene(path), path, c.phrase);
  }
}

// F6: an image bufferView past the end of its buffer (byteLength 1) is refused before any image decoder reads it.
TEST(ImportHardening, BufferViewPastItsBuffer) {
  auto dir = test::tempDir("view_past_buffer");
  std::string json = R"({"asset":{"version":"2.0"},"buffers":[{"byteLength":1}],)"
                     R"("bufferViews":[{"buffer":0,"byteOffset":100,"byteLength":50}],)"
                     R"("images":[{"bufferView":0,"mimeType":"image/png"}]})";
  auto path = writeFile(dir / "img.glb", glb(json, std::string(200, '\0')));
  expectCleanError(io::importScene(path), path, "bufferView 0 (bytes 100..150) runs past buffer 0 (1 bytes)");
}

TEST(ImportHardening, BufferUrisMustNameFilesThatHoldThem) {
  auto dir = test::tempDir("buffer_uris");
  auto good = triangleGltf(dir, "good.gltf");
  ASSERT_TRUE(io::importScene(good).ok());
  std::string text((std::istreambuf_iterator<char>(std::ifstream(good).rdbuf())), {});
  auto replace = [&](const std::string& from, const std::string& to) {
    std::string t = text;
    t.replace(t.find(from), from.size(), to);
    return t;
  };
  auto dot = writeFile(dir / "dot.gltf", replace(R"("uri":"tri.bin")", R"("uri":".")"));
  expectCleanError(io::importScene(dot), dot, "buffer 0 '.': is a directory, not a regular file");
  auto missing = writeFile(dir / "missing.gltf", replace(R"("uri":"tri.bin")", R"("uri":"nowhere.bin")"));
  expectCleanError(io::importScene(missing), missing, "buffer 0 'nowhere.bin': file not found");
  auto longer = writeFile(dir / "longer.gltf",
                          replace(R"("uri":"tri.bin","byteLength":36)", R"("uri":"tri.bin","byteLength":360)"));
  expectCleanError(io::importScene(longer), longer, "the file holds 36 bytes, byteLength says 360");
  // A byteLength that is no integer: the parser's own words, on one line.
  auto bad = writeFile(dir / "bad.gltf",
                       replace(R"("uri":"tri.bin","byteLength":36)", R"("uri":"tri.bin","byteLength":"36")"));
  expectCleanError(io::importScene(bad), bad, "byteLength");
}

// Missing images are errors in glTF as in OBJ (one policy: what a scene names must be there).
TEST(ImportHardening, GltfMissingImageRejected) {
  auto dir = test::tempDir("gltf_missing_image");
  auto path = triangleGltf(dir, "img.gltf", R"(,"images":[{"uri":"gone.png"}])");
  expectCleanError(io::importScene(path), path, "image 0 'gone.png': file not found");
  writeFile(dir / "bad.png", "\x89PNG\r\n\x1a\ngarbage");
  auto corrupt = triangleGltf(dir, "corrupt.gltf", R"(,"images":[{"uri":"bad.png"}])");
  expectCleanError(io::importScene(corrupt), corrupt, "image 0: cannot decode image");
  io::ImportOptions noTextures;
  noTextures.loadTextures = false;
  EXPECT_TRUE(io::importScene(path, noTextures).ok());
}

// A chain deeper than the limit is too deep, not a cycle; a real cycle still says cycle.
TEST(ImportHardening, DeepNodeChainIsNotACycle) {
  auto dir = test::tempDir("deep_chain");
  auto chain = [](int n) {
    std::string nodes = "[";
    for (int i = 0; i + 1 < n; ++i) nodes.append(R"({"children":[)").append(std::to_string(i + 1)).append("]},");
    return nodes.append(R"({"mesh":0}])");
  };
  EXPECT_TRUE(io::importScene(triangleGltf(dir, "ok.gltf", "", chain(1024))).ok());
  auto deep = triangleGltf(dir, "deep.gltf", "", chain(1025));
  expectCleanError(io::importScene(deep), deep, "node hierarchy deeper than 1024 levels");
  auto cycle = triangleGltf(dir, "cycle.gltf", "", R"([{"children":[1]},{"children":[0],"mesh":0}])");
  auto r = io::importScene(cycle);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().message.find("deeper"), std::string::npos) << r.error().message;
}

// M1: non-finite or overflowing placements and material factors are rejected at import, naming the input.
TEST(ImportHardening, NonFiniteTransformsAndFactorsRejected) {
  auto dir = test::tempDir("nonfinite");
  auto huge = triangleGltf(dir, "huge.gltf", "", R"([{"mesh":0,"matrix":[1e308,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]}])");
  expectCleanError(io::importScene(huge), huge, "placed by a NaN or infinite transform");
  auto far = triangleGltf(dir, "far.gltf", "", R"([{"mesh":0,"scale":[1e38,1e38,1e38],"translation":[3e38,0,0]}])");
  expectCleanError(io::importScene(far), far, "placed beyond float range");
  auto factor = triangleGltf(dir, "factor.gltf", R"(,"materials":[{"name":"m","emissiveFactor":[1,1e39,0]}])");
  // A material only matters once a mesh uses it: point the primitive at it.
  std::string text((std::istreambuf_iterator<char>(std::ifstream(factor).rdbuf())), {});
  text.replace(text.find(R"({"POSITION":0})"), 14, R"({"POSITION":0},"material":0)");
  writeFile(factor, text);
  expectCleanError(io::importScene(factor), factor, "material 0 'm': a factor is NaN or infinite");

  writeFile(dir / "nan.mtl", "newmtl red\nKd nan 0 0\n");
  auto obj = writeFile(dir / "nan.obj", "mtllib nan.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n");
  expectCleanError(io::importScene(obj), obj, "material 0 'red': a factor is NaN or infinite");
  auto normal = writeFile(dir / "nrm.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 nan\nf 1//1 2//1 3//1\n");
  expectCleanError(io::importScene(normal), normal, "has a non-finite normal");
  auto uv = writeFile(dir / "uv.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt inf 0\nf 1/1 2/1 3/1\n");
  expectCleanError(io::importScene(uv), uv, "has a non-finite texture coordinate");
}

// OBJ follows glTF: files the scene names must exist and decode.
TEST(ImportHardening, ObjMissingMtlAndBadTexturesRejected) {
  auto dir = test::tempDir("obj_files");
  const std::string tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\nf 1/1 2/1 3/1\n";
  auto noMtl = writeFile(dir / "nomtl.obj", "mtllib none.mtl\n" + tri);
  expectCleanError(io::importScene(noMtl), noMtl, "mtllib 'none.mtl': file not found");
  // Several files on one mtllib line: each must exist.
  writeFile(dir / "a.mtl", "newmtl m\nKd 1 0 0\n");
  writeFile(dir / "b c.mtl", "newmtl m\nKd 0 1 0\n");
  auto two = writeFile(dir / "two.obj", "mtllib a.mtl none.mtl\n" + tri);
  expectCleanError(io::importScene(two), two, "mtllib 'none.mtl': file not found");
  auto spaced = io::importScene(writeFile(dir / "spaced.obj", "mtllib b c.mtl\n" + tri)); // one name with a space
  ASSERT_TRUE(spaced.ok()) << spaced.error().message;
  EXPECT_EQ(spaced->materials[0].baseColorFactor.g, 1.0f);
  writeFile(dir / "missing.mtl", "newmtl m\nmap_Kd gone.png\n");
  auto missing = writeFile(dir / "missing.obj", "mtllib missing.mtl\n" + tri);
  expectCleanError(io::importScene(missing), missing, "material 'm' map_Kd 'gone.png': file not found");
  io::ImportOptions noTextures;
  noTextures.loadTextures = false;
  EXPECT_TRUE(io::importScene(missing, noTextures).ok());
  writeFile(dir / "corrupt.png", "\x89PNG\r\n\x1a\ngarbage");
  writeFile(dir / "corrupt.mtl", "newmtl m\nmap_Kd corrupt.png\n");
  auto corrupt = writeFile(dir / "corrupt.obj", "mtllib corrupt.mtl\n" + tri);
  expectCleanError(io::importScene(corrupt), corrupt, "map_Kd 'corrupt.png': cannot decode image");
  // A PNG header claiming 20000 x 1 pixels (stb reads no further than the header to learn the size).
  std::string png = "\x89PNG\r\n\x1a\n";
  png += std::string("\0\0\0\x0dIHDR", 8);
  png += std::string("\0\0\x4e\x20\0\0\0\x01\x08\x06\0\0\0", 13);
  png += std::string("\0\0\0\0", 4);
  writeFile(dir / "huge.png", png);
  writeFile(dir / "huge.mtl", "newmtl m\nmap_Kd huge.png\n");
  auto huge = writeFile(dir / "huge.obj", "mtllib huge.mtl\n" + tri);
  expectCleanError(io::importScene(huge), huge, "image is 20000x1, over the 16384-pixel limit per side");
}

// Names from the input (a glTF mesh name here) are escaped in messages.
TEST(ImportHardening, MessagesEscapeInputNames) {
  auto dir = test::tempDir("escape_names");
  auto path = triangleGltf(dir, "names.gltf");
  std::string text((std::istreambuf_iterator<char>(std::ifstream(path).rdbuf())), {});
  text.replace(text.find(R"({"attributes":{"POSITION":0}})"), 29, R"({"attributes":{}})");
  text.replace(text.find(R"("meshes":[{)"), 11, R"("meshes":[{"name":"\u001b[31mred\nline",)");
  writeFile(path, text);
  expectCleanError(io::importScene(path), path, "mesh '\\x1b[31mred\\x0aline': primitive without POSITION");
}

// The importer reproducers of the fuzzing campaign: one clean error each.
TEST(ImportHardening, FuzzRegressions) {
  auto dir = test::sharedFile("fuzz-regressions");
  if (dir.empty()) GTEST_SKIP() << "shared data absent: ../shared/data/fuzz-regressions";
  struct Case {
    const char* file;
    const char* phrase;
  } cases[] = {
      {"meshopt_tri_count100.glb", "mode TRIANGLES needs a count divisible by 3"},
      {"meshopt_tri_stride12.glb", "mode TRIANGLES needs byteStride 2 or 4"},
      {"meshopt_attr_stride3.glb", "mode ATTRIBUTES needs a byteStride divisible by 4"},
      {"city_buflen1.glb", "runs past buffer 0 (1 bytes)"},
      {"cube_nanmtl.obj", "a factor is NaN or infinite"},
      {"suzanne_hugematrix.gltf", "transform"},
  };
  for (const Case& c : cases) expectCleanError(io::importScene(dir / c.file), dir / c.file, c.phrase);
}
