/// @file ContactSheet.h
/// @brief Many stills tiled into one image, each labelled with its frame
///        number (a 5x7 pixel font, scaled), for reviewing a sequence at a glance.
#pragma once

#include "render/Image.h"

#include <string>
#include <vector>

namespace cascade::render {

struct ContactSheetTile {
  int frame = 0;  ///< printed in the tile's lower left corner
  Image image;    ///< any size; scaled to the tile size (area average)
};

/// Tiles `tiles` left to right, top to bottom on a dark background, `columns`
/// per row (0: as square a sheet as the tile aspect allows), the sheet at
/// most `maxWidth` pixels wide (tiles are never enlarged).
Image makeContactSheet(const std::vector<ContactSheetTile>& tiles, int columns = 0, int maxWidth = 2048);

/// Draws `text` (digits, '-', ' ' and '#'; other characters as blanks) with
/// its lower left corner at (x, y), `scale` pixels per font pixel, in
/// `color` on a dark translucent box.
void drawLabel(Image& image, int x, int y, const std::string& text, int scale,
               const std::uint8_t color[3]);

} // namespace cascade::render
