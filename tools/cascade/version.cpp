// `cascade --version`: Cascade's version and those of the libraries it was built with
// (headers at build time; assimp, libpng and oneTBB also as loaded at run time).
#include "Commands.h"
#include "HugePages.h"

#include "libsph/Version.h"

#include <CGAL/version.h>
#include <CLI/Version.hpp>
#include <Eigen/Core>
#include <GL/osmesa.h>
#include <assimp/version.h>
#include <nlohmann/json.hpp>
#include <oneapi/tbb/version.h>
#include <openvdb/version.h>
#include <png.h>

#include <string>

namespace cascade::cli {

std::string versionText() {
  const auto number = [](auto value) { return std::to_string(value); };
  std::string text = "cascade " + cascadeVersion() + "\n";
  text += "  OpenVDB " + std::string(OPENVDB_LIBRARY_VERSION_STRING) + "\n";
  text += "  oneTBB " + std::string(TBB_VERSION_STRING) + " (loaded " + TBB_runtime_version() + ")\n";
  text += "  Eigen " + number(EIGEN_WORLD_VERSION) + "." + number(EIGEN_MAJOR_VERSION) + "." +
          number(EIGEN_MINOR_VERSION) + "\n";
  text += "  CGAL " + std::string(CGAL_VERSION_STR) + "\n";
  text += "  assimp " + number(aiGetVersionMajor()) + "." + number(aiGetVersionMinor()) + "." +
          number(aiGetVersionPatch()) + "\n";
  text += "  OSMesa " + number(OSMESA_MAJOR_VERSION) + "." + number(OSMESA_MINOR_VERSION) + "\n";
  text += "  libpng " + std::string(PNG_LIBPNG_VER_STRING) + " (loaded " + png_get_libpng_ver(nullptr) + ")\n";
  text += "  nlohmann-json " + number(NLOHMANN_JSON_VERSION_MAJOR) + "." + number(NLOHMANN_JSON_VERSION_MINOR) + "." +
          number(NLOHMANN_JSON_VERSION_PATCH) + "\n";
  text += "  CLI11 " + std::string(CLI11_VERSION) + "\n";
  text += heapPagesText();
  return text;
}

} // namespace cascade::cli
