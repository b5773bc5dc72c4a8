// OSMesa loaded on first use (OsMesaLibrary.h).
#include "render/OsMesaLibrary.h"

#include <dlfcn.h>

#include <cstdlib>
#include <iterator>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace cascade::render {

namespace {

/// The runtime name (soname) first, then the development link, for a system whose
/// Mesa has another major version; CASCADE_OSMESA_LIBRARY (a file name or path) instead
/// of both, for another Mesa build.
constexpr const char* kNames[] = {"libOSMesa.so.8", "libOSMesa.so"};

template <typename Function>
void resolve(void* library, const char* name, Function& function) {
  function = reinterpret_cast<Function>(::dlsym(library, name));
  if (!function) throw std::runtime_error(std::string("render: libOSMesa has no ") + name);
}

OsMesaLibrary load() {
  std::vector<std::string> names(std::begin(kNames), std::end(kNames));
  if (const char* chosen = std::getenv("CASCADE_OSMESA_LIBRARY"); chosen && *chosen) names = {chosen};
  void* library = nullptr;
  std::string reasons;
  for (const std::string& name : names) {
    // Local: OSMesa's (and LLVM's) symbols stay out of the global namespace.
    library = ::dlopen(name.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (library) break;
    const char* reason = ::dlerror();
    reasons += (reasons.empty() ? "" : "; ") + (reason ? std::string(reason) : name);
  }
  if (!library)
    throw std::runtime_error("render: cannot load Mesa's off-screen OpenGL (" + reasons +
                             "; Debian package libosmesa6)");
  OsMesaLibrary entry;
  resolve(library, "OSMesaCreateContextAttribs", entry.createContextAttribs);
  resolve(library, "OSMesaMakeCurrent", entry.makeCurrent);
  resolve(library, "OSMesaDestroyContext", entry.destroyContext);
  resolve(library, "OSMesaGetProcAddress", entry.getProcAddress);
  return entry;
}

} // namespace

const OsMesaLibrary& osMesa() {
  // Under a mutex, not call_once: a failed load throws, and the next call tries again.
  static std::mutex mutex;
  static OsMesaLibrary library;
  std::lock_guard<std::mutex> lock(mutex);
  if (!library.getProcAddress) library = load();
  return library;
}

} // namespace cascade::render
