// PNG round trips, sRGB transfer, thumbnails and contact sheets (render/Image.h, render/ContactSheet.h).
#include "render/ContactSheet.h"
#include "render/Image.h"

#include "libsph/Errors.h"

#include "TestTempDir.h"

#include <gtest/gtest.h>

#include <fstream>
#include <random>

using namespace cascade;
using namespace cascade::render;
namespace fs = std::filesystem;
using cascade::test::freshTempDir;

namespace {
Image noise(int width, int height, unsigned seed) {
  Image image(width, height);
  std::mt19937 random(seed);
  for (auto& byte : image.rgba) byte = std::uint8_t(random() & 0xff);
  return image;
}
} // namespace

TEST(Png, RoundTripKeepsEveryPixelAndTheText) {
  const fs::path dir = freshTempDir("render_png");
  const Image image = noise(37, 23, 1);
  writePng(dir / "rgba.png", image, true, {{"cascade-render", "settings 1"}});
  PngText text;
  const Image back = readPng(dir / "rgba.png", &text);
  ASSERT_EQ(back.width, 37);
  ASSERT_EQ(back.height, 23);
  EXPECT_EQ(back.rgba, image.rgba);
  EXPECT_EQ(text.at("cascade-render"), "settings 1");
  EXPECT_EQ(readPngText(dir / "rgba.png").at("cascade-render"), "settings 1");

  // RGB: colour kept, alpha read back opaque.
  writePng(dir / "rgb.png", image, false);
  const Image rgb = readPng(dir / "rgb.png");
  for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
    ASSERT_EQ(rgb.rgba[i], image.rgba[i]);
    ASSERT_EQ(rgb.rgba[i + 1], image.rgba[i + 1]);
    ASSERT_EQ(rgb.rgba[i + 2], image.rgba[i + 2]);
    ASSERT_EQ(rgb.rgba[i + 3], 255);
  }
  // Nothing but the two files (no temporaries left behind).
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator{}), 2);
  fs::remove_all(dir);
}

TEST(Png, BrokenOrMissingFileIsInputErrorNamingIt) {
  const fs::path dir = freshTempDir("render_png_bad");
  writePng(dir / "whole.png", noise(64, 64, 2), false);
  std::string bytes;
  {
    std::ifstream in(dir / "whole.png", std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  std::ofstream(dir / "cut.png", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  for (const char* name : {"cut.png", "missing.png"}) {
    try {
      readPng(dir / name);
      FAIL() << name << " should not read";
    } catch (const InputError& error) {
      EXPECT_NE(std::string(error.what()).find(name), std::string::npos) << error.what();
    }
  }
  fs::remove_all(dir);
}

TEST(Png, SrgbTransferIsInvertibleAndMatchesTheStandard) {
  EXPECT_NEAR(linearToSrgb(0.5f), 0.7354f, 1e-3);  // IEC 61966-2-1
  EXPECT_NEAR(srgbToLinear(0.5f), 0.2140f, 1e-3);
  for (int i = 0; i <= 255; ++i)
    EXPECT_EQ(int(std::lround(255 * linearToSrgb(srgbToLinear(i / 255.0f)))), i);
}

TEST(Png, ResizeAveragesInLinearLight) {
  // A 2x1 black/white pair halves to linear grey 0.5, i.e. sRGB 188, not 128.
  Image pair(2, 1);
  for (int c = 0; c < 3; ++c) pair.pixel(1, 0)[c] = 255;
  pair.pixel(0, 0)[3] = pair.pixel(1, 0)[3] = 255;
  const Image half = resizeImage(pair, 1, 1);
  EXPECT_NEAR(half.pixel(0, 0)[0], 188, 1);
  EXPECT_EQ(half.pixel(0, 0)[3], 255);
}

TEST(ContactSheet, TilesFramesInOrderWithTheirNumbers) {
  std::vector<ContactSheetTile> tiles;
  for (int frame = 1; frame <= 5; ++frame) {
    Image image(160, 90);
    for (std::size_t i = 0; i < image.rgba.size(); i += 4) {
      image.rgba[i] = std::uint8_t(frame * 40);  // a distinct red per frame
      image.rgba[i + 3] = 255;
    }
    tiles.push_back({frame, image});
  }
  const Image sheet = makeContactSheet(tiles, 3, 2048);
  // 3 columns, 2 rows of 160x90 tiles with 4 px gaps.
  ASSERT_EQ(sheet.width, 4 + 3 * (160 + 4));
  ASSERT_EQ(sheet.height, 4 + 2 * (90 + 4));
  for (int t = 0; t < 5; ++t) {  // tile centres keep their frame's colour
    const int x = 4 + (t % 3) * 164 + 120, y = 4 + (t / 3) * 94 + 20;
    EXPECT_EQ(sheet.pixel(x, y)[0], (t + 1) * 40) << "tile " << t;
  }
  // The label: white glyph pixels in the lower left corner of each tile.
  for (int t = 0; t < 5; ++t) {
    int white = 0;
    const int x0 = 4 + (t % 3) * 164, y0 = 4 + (t / 3) * 94;
    for (int y = y0 + 70; y < y0 + 90; ++y)
      for (int x = x0; x < x0 + 20; ++x)
        if (sheet.pixel(x, y)[0] == 255 && sheet.pixel(x, y)[1] == 255) ++white;
    EXPECT_GT(white, 5) << "tile " << t;
  }
  // The unused sixth slot stays background.
  EXPECT_EQ(sheet.pixel(4 + 2 * 164 + 80, 4 + 94 + 45)[0], 24);
}
