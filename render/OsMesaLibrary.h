/// @file OsMesaLibrary.h
/// @brief Mesa's off-screen OpenGL (OSMesa, llvmpipe), loaded with dlopen when the
///        first preview renderer is made, not linked.
///
/// libOSMesa pulls in LLVM, and resolving their symbols at start-up took about 55 ms
/// of every `cascade` process here, whatever its subcommand (twice for those that
/// restart on huge pages). Loaded on first use, only `cascade render` (and the stages
/// that draw previews) pay it. The GL entry points themselves come from
/// OSMesaGetProcAddress (PreviewRenderer.cpp). CASCADE_OSMESA_LIBRARY names another
/// library to load (a Mesa build of one's own).
/// Include only in .cpp files that use OSMesa (it includes GL/osmesa.h).
#pragma once

#include <GL/osmesa.h>

namespace cascade::render {

/// The OSMesa entry points the renderer uses.
struct OsMesaLibrary {
  decltype(&::OSMesaCreateContextAttribs) createContextAttribs = nullptr;
  decltype(&::OSMesaMakeCurrent) makeCurrent = nullptr;
  decltype(&::OSMesaDestroyContext) destroyContext = nullptr;
  decltype(&::OSMesaGetProcAddress) getProcAddress = nullptr;
};

/// The library, loaded once (thread safe; it stays loaded). Throws std::runtime_error
/// naming the library and the loader's reason when it cannot be loaded.
const OsMesaLibrary& osMesa();

} // namespace cascade::render
