#pragma once
// Generated texture sheets (flipbooks) for the example effects: no downloaded assets. Each tile is
// one frame of a procedural sprite that evolves across the sheet (row-major from the top left,
// the order of RenderParticle::frame). Grey RGB equal to the alpha, so a renderer may take the
// alpha from the alpha channel or (alpha_from_greyscale) from the luminance alike.
#include <cstdint>
#include <string_view>

#include "mirage/core/image.h"
#include "mirage/core/result.h"
#include "mirage/particles/effect.h"

namespace mirage::particles {

// kind: "puff" (soft value-noise smoke puff that spreads and thins), "spark" (a bright core with a
// streak that shortens), "flame" (a tongue that flickers and shrinks), "drop" (a thin rain
// streak), "none" (a soft disc). Deterministic for (kind, tiles, tileSize, seed).
// Error: an unknown kind, zero tiles or a sheet over 4096 pixels a side.
Result<ImageRGBA8> generateSheet(std::string_view kind, uint32_t tilesX, uint32_t tilesY, uint32_t tileSize,
                                 uint32_t seed = 1);

// Pixels a side of one generated sheet tile.
inline constexpr uint32_t kSheetTilePixels = 32;
// A system's sheet, as every renderer draws it: generateSheet(texture, tiles, kSheetTilePixels).
// Errors name the system.
Result<ImageRGBA8> systemSheet(const SystemDef& system);

} // namespace mirage::particles
