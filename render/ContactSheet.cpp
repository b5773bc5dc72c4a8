#include "render/ContactSheet.h"

#include <algorithm>
#include <cmath>

namespace cascade::render {

namespace {

// 5x7 glyphs, one byte per row, bit 4 = leftmost column.
const std::uint8_t* glyph(char c) {
  static const std::uint8_t digits[10][7] = {
      {0x0E, 0x11, 0x13, 0x15, 0x19, 0x11, 0x0E}, {0x04, 0x0C, 0x04, 0x04, 0x04, 0x04, 0x0E},
      {0x0E, 0x11, 0x01, 0x02, 0x04, 0x08, 0x1F}, {0x1F, 0x02, 0x04, 0x02, 0x01, 0x11, 0x0E},
      {0x02, 0x06, 0x0A, 0x12, 0x1F, 0x02, 0x02}, {0x1F, 0x10, 0x1E, 0x01, 0x01, 0x11, 0x0E},
      {0x06, 0x08, 0x10, 0x1E, 0x11, 0x11, 0x0E}, {0x1F, 0x01, 0x02, 0x04, 0x08, 0x08, 0x08},
      {0x0E, 0x11, 0x11, 0x0E, 0x11, 0x11, 0x0E}, {0x0E, 0x11, 0x11, 0x0F, 0x01, 0x02, 0x0C}};
  static const std::uint8_t dash[7] = {0, 0, 0, 0x1F, 0, 0, 0};
  static const std::uint8_t hash[7] = {0x0A, 0x0A, 0x1F, 0x0A, 0x1F, 0x0A, 0x0A};
  static const std::uint8_t blank[7] = {0, 0, 0, 0, 0, 0, 0};
  if (c >= '0' && c <= '9') return digits[c - '0'];
  if (c == '-') return dash;
  if (c == '#') return hash;
  return blank;
}

void blendPixel(Image& image, int x, int y, const std::uint8_t color[3], float alpha) {
  if (x < 0 || y < 0 || x >= image.width || y >= image.height) return;
  std::uint8_t* p = image.pixel(x, y);
  for (int c = 0; c < 3; ++c) p[c] = std::uint8_t(std::lround(p[c] * (1 - alpha) + color[c] * alpha));
  p[3] = 255;
}

} // namespace

void drawLabel(Image& image, int x, int y, const std::string& text, int scale, const std::uint8_t color[3]) {
  scale = std::max(1, scale);
  const int advance = 6 * scale, pad = 2 * scale;
  const int boxWidth = int(text.size()) * advance - scale + 2 * pad, boxHeight = 7 * scale + 2 * pad;
  const std::uint8_t shade[3] = {0, 0, 0};
  for (int j = 0; j < boxHeight; ++j)
    for (int i = 0; i < boxWidth; ++i) blendPixel(image, x + i, y - boxHeight + 1 + j, shade, 0.55f);
  for (std::size_t k = 0; k < text.size(); ++k) {
    const std::uint8_t* rows = glyph(text[k]);
    for (int row = 0; row < 7; ++row)
      for (int column = 0; column < 5; ++column) {
        if (!(rows[row] & (0x10 >> column))) continue;
        for (int sy = 0; sy < scale; ++sy)
          for (int sx = 0; sx < scale; ++sx)
            blendPixel(image, x + pad + int(k) * advance + column * scale + sx,
                       y - boxHeight + 1 + pad + row * scale + sy, color, 1.0f);
      }
  }
}

Image makeContactSheet(const std::vector<ContactSheetTile>& tiles, int columns, int maxWidth) {
  if (tiles.empty()) return Image();
  const Image& first = tiles.front().image;
  const int sourceWidth = std::max(1, first.width), sourceHeight = std::max(1, first.height);
  const int count = int(tiles.size());
  if (columns <= 0) {  // aim at a 16:9 sheet
    const double aspect = double(sourceWidth) / sourceHeight;
    columns = int(std::lround(std::sqrt(count * (16.0 / 9.0) / aspect)));
  }
  columns = std::clamp(columns, 1, count);
  const int rows = (count + columns - 1) / columns;
  const int gap = 4;
  int tileWidth = std::min(sourceWidth, (maxWidth - gap * (columns + 1)) / columns);
  tileWidth = std::max(tileWidth, 16);
  const int tileHeight = std::max(1, int(std::lround(double(tileWidth) * sourceHeight / sourceWidth)));
  Image sheet(gap + columns * (tileWidth + gap), gap + rows * (tileHeight + gap));
  for (std::size_t i = 0; i < sheet.rgba.size(); i += 4) {
    sheet.rgba[i] = sheet.rgba[i + 1] = sheet.rgba[i + 2] = 24;
    sheet.rgba[i + 3] = 255;
  }
  const int scale = tileWidth >= 120 ? std::max(2, tileWidth / 140) : 1;
  const std::uint8_t white[3] = {255, 255, 255};
  for (int t = 0; t < count; ++t) {
    const int x0 = gap + (t % columns) * (tileWidth + gap), y0 = gap + (t / columns) * (tileHeight + gap);
    const Image& source = tiles[std::size_t(t)].image;
    if (!source.empty()) {
      const Image tile = resizeImage(source, tileWidth, tileHeight);
      for (int y = 0; y < tileHeight; ++y)
        for (int x = 0; x < tileWidth; ++x) {
          std::uint8_t* q = sheet.pixel(x0 + x, y0 + y);
          const std::uint8_t* p = tile.pixel(x, y);
          q[0] = p[0], q[1] = p[1], q[2] = p[2], q[3] = 255;
        }
    }
    drawLabel(sheet, x0 + 2 * scale, y0 + tileHeight - 1 - 2 * scale, std::to_string(tiles[std::size_t(t)].frame),
              scale, white);
  }
  return sheet;
}

} // namespace cascade::render
