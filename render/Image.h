/// @file Image.h
/// @brief An 8-bit RGBA raster (sRGB-encoded colour, linear alpha = coverage)
///        and its PNG reader and writer (libpng; files written atomically,
///        tagged sRGB, with optional tEXt key/value pairs).
///
/// Rows are stored top to bottom, pixels left to right, 4 bytes per pixel.
/// libpng headers stay in Image.cpp.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

namespace cascade::render {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  ///< width * height * 4 bytes, top row first

  Image() = default;
  Image(int w, int h) : width(w), height(h), rgba(std::size_t(w) * std::size_t(h) * 4, 0) {}

  bool empty() const { return width == 0 || height == 0; }
  std::uint8_t* pixel(int x, int y) { return &rgba[(std::size_t(y) * width + x) * 4]; }
  const std::uint8_t* pixel(int x, int y) const { return &rgba[(std::size_t(y) * width + x) * 4]; }
};

/// Text chunks stored in (and read back from) a PNG.
using PngText = std::map<std::string, std::string>;

/// Writes `image` as an 8-bit sRGB PNG, atomically (whole file or nothing).
/// `withAlpha` false writes RGB (an opaque preview); true keeps the alpha channel.
void writePng(const std::filesystem::path& path, const Image& image, bool withAlpha = false,
              const PngText& text = {});

/// Reads an 8-bit (or palette/grey, expanded) PNG into RGBA; missing alpha becomes 255.
/// A missing or broken file throws InputError naming the file.
Image readPng(const std::filesystem::path& path, PngText* text = nullptr);

/// Reads only the tEXt chunks before the image data (cheap); empty if unreadable.
PngText readPngText(const std::filesystem::path& path);

/// Area-averaging resize (box filter over the covered source pixels), for
/// thumbnails; averages in linear light and re-encodes sRGB.
Image resizeImage(const Image& source, int width, int height);

/// sRGB transfer functions (IEC 61966-2-1).
float srgbToLinear(float encoded);
float linearToSrgb(float linear);

} // namespace cascade::render
