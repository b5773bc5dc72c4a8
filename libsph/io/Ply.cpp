#include "libsph/io/Ply.h"

#include "libsph/Errors.h"
#include "libsph/io/AtomicFile.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <fstream>
#include <stdexcept>
#include <cstring>
#include <sstream>

namespace cascade {

namespace {

bool parsePlyType(const std::string& name, PlyType& type) {
  if (name == "char" || name == "int8") type = PlyType::Int8;
  else if (name == "uchar" || name == "uint8") type = PlyType::UInt8;
  else if (name == "short" || name == "int16") type = PlyType::Int16;
  else if (name == "ushort" || name == "uint16") type = PlyType::UInt16;
  else if (name == "int" || name == "int32") type = PlyType::Int32;
  else if (name == "uint" || name == "uint32") type = PlyType::UInt32;
  else if (name == "float" || name == "float32") type = PlyType::Float32;
  else if (name == "double" || name == "float64") type = PlyType::Float64;
  else return false;
  return true;
}

template <class T>
double load(const char* bytes) {
  T value;
  std::memcpy(&value, bytes, sizeof value);
  return double(value);
}

} // namespace

int PlyElement::find(const std::string& name) const {
  for (std::size_t c = 0; c < properties.size(); ++c)
    if (properties[c].name == name) return int(c);
  return -1;
}

std::size_t plyTypeSize(PlyType type) {
  switch (type) {
    case PlyType::Int8: case PlyType::UInt8: return 1;
    case PlyType::Int16: case PlyType::UInt16: return 2;
    case PlyType::Int32: case PlyType::UInt32: case PlyType::Float32: return 4;
    case PlyType::Float64: return 8;
  }
  return 0;
}

PlyReader::PlyReader(const std::filesystem::path& path, bool headerOnly)
    : mWhere(path.string() + ": "), mHeaderOnly(headerOnly) {
  if (!headerOnly) {
    mData = readTextFile(path);  // InputError if it cannot be read
  } else {  // up to the line after "end_header" (a header is at most a few kB; 1 MiB bounds the search)
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(mWhere + "cannot open file");
    char chunk[4096];
    while (in && mData.size() < (std::size_t(1) << 20)) {
      in.read(chunk, sizeof chunk);
      mData.append(chunk, std::size_t(in.gcount()));
      const std::size_t end = mData.find("end_header");
      if (end != std::string::npos && mData.find('\n', end) != std::string::npos) break;
    }
  }
  const std::size_t headerEnd = mData.find("end_header");
  if (mData.compare(0, 3, "ply") != 0 || headerEnd == std::string::npos) throw InputError(mWhere + "not a PLY file");
  std::istringstream header(mData.substr(0, headerEnd));
  std::string line, format;
  int lineNumber = 0;
  while (std::getline(header, line)) {
    ++lineNumber;
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    auto bad = [&](const std::string& what) {
      throw InputError(mWhere + "header line " + std::to_string(lineNumber) + ": " + what);
    };
    if (keyword == "format") {
      words >> format;
    } else if (keyword == "comment") {
      std::string text;
      std::getline(words >> std::ws, text);
      mComments.push_back(text);
    } else if (keyword == "element") {
      PlyElement element;
      long long count = -1;
      words >> element.name >> count;
      if (!words || count < 0) bad("element needs a name and a count");
      element.count = std::size_t(count);
      mElements.push_back(element);
    } else if (keyword == "property") {
      if (mElements.empty()) bad("property before any element");
      PlyProperty property;
      std::string type;
      words >> type;
      if (type == "list") {
        property.isList = true;
        std::string countType, itemType;
        words >> countType >> itemType;
        if (!parsePlyType(countType, property.countType) || !parsePlyType(itemType, property.type))
          bad("unknown list types '" + countType + " " + itemType + "'");
        if (property.countType == PlyType::Float32 || property.countType == PlyType::Float64)
          bad("a list count must be an integer type");
      } else if (!parsePlyType(type, property.type)) {
        bad("unknown property type '" + type + "'");
      }
      words >> property.name;
      if (property.name.empty()) bad("property without a name");
      mElements.back().properties.push_back(property);
    }
  }
  std::size_t bodyStart = mData.find('\n', headerEnd);
  if (bodyStart == std::string::npos) throw InputError(mWhere + "truncated PLY header");
  mBodyStart = mPosition = bodyStart + 1;
  if (format == "ascii") mBinary = false;
  else if (format != "binary_little_endian")
    throw InputError(mWhere + "unsupported PLY format '" + format + "' (ascii or binary_little_endian)");
}

void PlyReader::truncated(const PlyElement& element, std::size_t recordIndex) const {
  throw InputError(mWhere + "truncated: holds " + std::to_string(recordIndex) + " of " + std::to_string(element.count) +
                   " " + element.name + (element.count == 1 ? "" : "s"));
}

double PlyReader::readBinary(PlyType type, const PlyElement& element, std::size_t recordIndex) {
  const std::size_t size = plyTypeSize(type);
  if (mPosition + size > mData.size()) truncated(element, recordIndex);
  const char* bytes = mData.data() + mPosition;
  mPosition += size;
  switch (type) {
    case PlyType::Int8: return load<std::int8_t>(bytes);
    case PlyType::UInt8: return load<std::uint8_t>(bytes);
    case PlyType::Int16: return load<std::int16_t>(bytes);
    case PlyType::UInt16: return load<std::uint16_t>(bytes);
    case PlyType::Int32: return load<std::int32_t>(bytes);
    case PlyType::UInt32: return load<std::uint32_t>(bytes);
    case PlyType::Float32: return load<float>(bytes);
    case PlyType::Float64: return load<double>(bytes);
  }
  return 0;
}

double PlyReader::readAscii(const PlyElement& element, std::size_t recordIndex) {
  while (mPosition < mData.size() && std::isspace(static_cast<unsigned char>(mData[mPosition]))) ++mPosition;
  if (mPosition >= mData.size()) truncated(element, recordIndex);
  double value = 0;
  const char* first = mData.data() + mPosition;
  const auto [end, error] = std::from_chars(first, mData.data() + mData.size(), value);
  if (error != std::errc())
    throw InputError(mWhere + element.name + " " + std::to_string(recordIndex) + ": not a number");
  mPosition += std::size_t(end - first);
  return value;
}

void PlyReader::readRecord(const PlyElement& element, std::size_t recordIndex) {
  mList.clear();
  for (std::size_t c = 0; c < element.properties.size(); ++c) {
    const PlyProperty& property = element.properties[c];
    if (!property.isList) {
      mValues[c] = mBinary ? readBinary(property.type, element, recordIndex) : readAscii(element, recordIndex);
      continue;
    }
    const double count = mBinary ? readBinary(property.countType, element, recordIndex)
                                 : readAscii(element, recordIndex);
    if (!(count >= 0) || count != double(std::size_t(count)))
      throw InputError(mWhere + element.name + " " + std::to_string(recordIndex) + ": bad list count");
    const std::size_t items = std::size_t(count);
    mValues[c] = count;
    mList.clear();
    if (mBinary && mPosition + items * plyTypeSize(property.type) > mData.size()) truncated(element, recordIndex);
    for (std::size_t k = 0; k < items; ++k)
      mList.push_back(mBinary ? readBinary(property.type, element, recordIndex) : readAscii(element, recordIndex));
  }
}

void PlyReader::seek(std::size_t index) {
  if (mHeaderOnly) throw std::logic_error("PlyReader: records read from a header-only reader");
  if (index >= mElements.size()) throw InputError(mWhere + "no such PLY element");
  if (index < mElement) {  // back to the start of the body
    mPosition = mBodyStart;
    mElement = 0;
  }
  for (; mElement < index; ++mElement) {
    const PlyElement& element = mElements[mElement];
    bool fixed = mBinary;
    std::size_t stride = 0;
    for (const PlyProperty& property : element.properties) {
      fixed = fixed && !property.isList;
      stride += plyTypeSize(property.type);
    }
    if (fixed) {  // skip whole records at once
      if (mPosition + element.count * stride > mData.size())
        truncated(element, (mData.size() - mPosition) / std::max<std::size_t>(stride, 1));
      mPosition += element.count * stride;
      continue;
    }
    mValues.resize(element.properties.size());
    for (std::size_t i = 0; i < element.count; ++i) readRecord(element, i);
  }
}

} // namespace cascade
