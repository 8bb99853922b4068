#pragma once
// Image files: PNG/JPG in (stb_image), PNG out, OpenEXR and PFM out for linear float images.
// Every writer is atomic: it writes "<path>.tmp-<pid>" and renames it over <path>, so readers never
// see a partial file and a failed write leaves nothing behind. Errors name the file.
#include <cstdint>
#include <filesystem>
#include <span>

#include "mirage/core/color.h"
#include "mirage/core/image.h"
#include "mirage/core/result.h"

namespace mirage::io {

// Any format stb_image decodes (PNG, JPG, BMP, TGA, ...), converted to 8-bit RGBA.
Result<ImageRGBA8> readPng(const std::filesystem::path& path);
Status writePng(const std::filesystem::path& path, const ImageRGBA8& image);

// OpenEXR 2.0, single-part scanline, NO_COMPRESSION, channels A,B,G,R as 32-bit FLOAT.
Status writeExr(const std::filesystem::path& path, const ImageF32& image);
// Reads exactly the layout writeExr produces (any channel set other than FLOAT A,B,G,R, any
// compression, tiles or multi-part files are rejected with an error).
Result<ImageF32> readExr(const std::filesystem::path& path);

// Portable float map: "PF" (RGB, alpha dropped), little-endian floats, rows bottom to top.
Status writePfm(const std::filesystem::path& path, const ImageF32& image);

// Write bytes atomically (temp file + rename); the building block of every writer above.
Status writeFileAtomic(const std::filesystem::path& path, const void* data, size_t size);
// Same, for a file assembled from several buffers (avoids concatenating large payloads first).
Status writeFileAtomic(const std::filesystem::path& path, std::span<const std::span<const uint8_t>> parts);

// sRGB helpers live in mirage/core/color.h (renderers need them too).
using mirage::linearToSrgb8;
using mirage::srgb8ToLinear;

} // namespace mirage::io
