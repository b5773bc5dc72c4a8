#include "render/Image.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"
#include "libsph/Version.h"

#include <png.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <memory>
#include <stdexcept>

namespace cascade::render {

namespace fs = std::filesystem;

float srgbToLinear(float encoded) {
  return encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
}

float linearToSrgb(float linear) {
  linear = std::clamp(linear, 0.0f, 1.0f);
  return linear <= 0.0031308f ? linear * 12.92f : 1.055f * std::pow(linear, 1.0f / 2.4f) - 0.055f;
}

namespace {

struct FileCloser {
  void operator()(std::FILE* file) const { if (file) std::fclose(file); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

// libpng reports errors through longjmp by default; we route them into an
// error string and longjmp back to the setjmp in the caller.
struct PngErrorState {
  std::string message;
};

void pngError(png_structp png, png_const_charp message) {
  auto* state = static_cast<PngErrorState*>(png_get_error_ptr(png));
  if (state) state->message = message ? message : "libpng error";
  png_longjmp(png, 1);
}

void pngWarning(png_structp, png_const_charp) {}

} // namespace

namespace {

// The libpng calls of a write, with setjmp in a frame of plain data only
// (libpng longjmps here on error).
bool writePngStream(std::FILE* file, const Image& image, bool withAlpha, png_text* chunks, int chunkCount,
                    std::uint8_t* row, PngErrorState& state) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &state, pngError, pngWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, &info);
    state.message = "libpng initialisation failed";
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, file);
  png_set_compression_level(png, 6);
  png_set_IHDR(png, info, png_uint_32(image.width), png_uint_32(image.height), 8,
               withAlpha ? PNG_COLOR_TYPE_RGB_ALPHA : PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  if (chunkCount > 0) png_set_text(png, info, chunks, chunkCount);
  png_write_info(png, info);
  const int channels = withAlpha ? 4 : 3;
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t* source = image.pixel(0, y);
    for (int x = 0; x < image.width; ++x)
      for (int c = 0; c < channels; ++c) row[x * channels + c] = source[x * 4 + c];
    png_write_row(png, row);
  }
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

} // namespace

void writePng(const fs::path& path, const Image& image, bool withAlpha, const PngText& text) {
  if (image.empty()) throw std::invalid_argument(path.string() + ": cannot write an empty image");
  writeFileAtomically(path, [&](const fs::path& temp) {
    FilePtr file(std::fopen(temp.c_str(), "wb"));
    if (!file) throw std::runtime_error(path.string() + ": cannot open for writing");
    std::vector<std::uint8_t> row(std::size_t(image.width) * 4);
    std::vector<png_text> chunks;
    PngText stamped = text;
    stamped.emplace("Software", "cascade " + cascadeVersion());  // PNG's keyword for the writer
    for (const auto& [key, value] : stamped) {
      png_text chunk{};
      chunk.compression = PNG_TEXT_COMPRESSION_NONE;
      chunk.key = const_cast<char*>(key.c_str());
      chunk.text = const_cast<char*>(value.c_str());
      chunk.text_length = value.size();
      chunks.push_back(chunk);
    }
    PngErrorState state;
    if (!writePngStream(file.get(), image, withAlpha, chunks.data(), int(chunks.size()), row.data(), state))
      throw std::runtime_error(path.string() + ": " + state.message);
    if (std::fflush(file.get()) != 0 || std::ferror(file.get()))
      throw std::runtime_error(path.string() + ": write failed");
  });
}

namespace {

// C++ work on behalf of readPngStream, kept out of the frame that holds the
// setjmp (so nothing there can be clobbered by libpng's longjmp).
[[gnu::noinline]] void collectText(png_structp png, png_infop info, PngText* text) {
  png_textp chunks = nullptr;
  int count = 0;
  png_get_text(png, info, &chunks, &count);
  for (int i = 0; i < count; ++i) (*text)[chunks[i].key] = std::string(chunks[i].text, chunks[i].text_length);
}

[[gnu::noinline]] void allocateImage(Image* image, png_uint_32 width, png_uint_32 height) {
  *image = Image(int(width), int(height));
}

[[gnu::noinline]] void setMessage(PngErrorState& state, const char* message) {
  if (state.message.empty()) state.message = message;
}

// Reads the header (and text chunks) and, if `image` is given, the pixels;
// setjmp lives in this frame, which holds plain data only.
bool readPngStream(std::FILE* file, Image* image, PngText* text, PngErrorState& state) {
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &state, pngError, pngWarning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_read_struct(&png, &info, nullptr);
    setMessage(state, "libpng initialisation failed");
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_read_struct(&png, &info, nullptr);
    setMessage(state, "broken PNG");
    return false;
  }
  png_init_io(png, file);
  png_set_sig_bytes(png, 8);
  png_read_info(png, info);
  if (text) collectText(png, info, text);
  if (image) {
    const png_byte colorType = png_get_color_type(png, info);
    const png_byte bitDepth = png_get_bit_depth(png, info);
    if (colorType == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (colorType == PNG_COLOR_TYPE_GRAY && bitDepth < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    if (bitDepth == 16) png_set_strip_16(png);
    if (colorType == PNG_COLOR_TYPE_GRAY || colorType == PNG_COLOR_TYPE_GRAY_ALPHA)
      png_set_gray_to_rgb(png);
    if (!(colorType & PNG_COLOR_MASK_ALPHA)) png_set_filler(png, 0xff, PNG_FILLER_AFTER);
    png_read_update_info(png, info);
    const png_uint_32 width = png_get_image_width(png, info);
    const png_uint_32 height = png_get_image_height(png, info);
    if (png_get_rowbytes(png, info) != std::size_t(width) * 4 || width > 65536 || height > 65536) {
      png_destroy_read_struct(&png, &info, nullptr);
      setMessage(state, "unsupported PNG layout");
      return false;
    }
    allocateImage(image, width, height);
    for (png_uint_32 y = 0; y < height; ++y) png_read_row(png, image->pixel(0, int(y)), nullptr);
    png_read_end(png, nullptr);
  }
  png_destroy_read_struct(&png, &info, nullptr);
  return true;
}

bool readPngImpl(const fs::path& path, Image* image, PngText* text, std::string& error) {
  FilePtr file(std::fopen(path.c_str(), "rb"));
  if (!file) {
    error = "cannot open file";
    return false;
  }
  std::array<unsigned char, 8> signature{};
  if (std::fread(signature.data(), 1, 8, file.get()) != 8 || png_sig_cmp(signature.data(), 0, 8)) {
    error = "not a PNG file";
    return false;
  }
  PngErrorState state;
  if (!readPngStream(file.get(), image, text, state)) {
    error = state.message;
    return false;
  }
  return true;
}

} // namespace

Image readPng(const fs::path& path, PngText* text) {
  Image image;
  std::string error;
  if (!readPngImpl(path, &image, text, error)) throw InputError(path.string() + ": " + error);
  return image;
}

PngText readPngText(const fs::path& path) {
  PngText text;
  std::string error;
  if (!readPngImpl(path, nullptr, &text, error)) return {};
  return text;
}

Image resizeImage(const Image& source, int width, int height) {
  Image result(width, height);
  if (source.empty() || width <= 0 || height <= 0) return result;
  std::array<float, 256> toLinear;
  for (int i = 0; i < 256; ++i) toLinear[i] = srgbToLinear(float(i) / 255.0f);
  const double scaleX = double(source.width) / width, scaleY = double(source.height) / height;
  for (int y = 0; y < height; ++y) {
    const double y0 = y * scaleY, y1 = (y + 1) * scaleY;
    for (int x = 0; x < width; ++x) {
      const double x0 = x * scaleX, x1 = (x + 1) * scaleX;
      double sum[4] = {0, 0, 0, 0}, weightSum = 0;
      for (int sy = int(y0); sy < std::min(source.height, int(std::ceil(y1))); ++sy) {
        const double wy = std::min(y1, sy + 1.0) - std::max(y0, double(sy));
        for (int sx = int(x0); sx < std::min(source.width, int(std::ceil(x1))); ++sx) {
          const double weight = wy * (std::min(x1, sx + 1.0) - std::max(x0, double(sx)));
          const std::uint8_t* p = source.pixel(sx, sy);
          for (int c = 0; c < 3; ++c) sum[c] += weight * toLinear[p[c]];
          sum[3] += weight * p[3];
          weightSum += weight;
        }
      }
      std::uint8_t* q = result.pixel(x, y);
      for (int c = 0; c < 3; ++c)
        q[c] = std::uint8_t(std::lround(255.0f * linearToSrgb(float(sum[c] / weightSum))));
      q[3] = std::uint8_t(std::lround(sum[3] / weightSum));
    }
  }
  return result;
}

} // namespace cascade::render
