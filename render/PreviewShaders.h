/// @file PreviewShaders.h
/// @brief GLSL 3.30 sources of PreviewRenderer's passes (internal to render/).
#pragma once

namespace cascade::render::shaders {

extern const char* const kCommon;          ///< sky, lights, shadow lookup (prepended to fragment shaders)
extern const char* const kMeshVertex;      ///< position + normal (+ colour, cutaway) to world
extern const char* const kDepthVertex;     ///< position to clip only (shadow map, back faces)
extern const char* const kDepthFragment;   ///< writes nothing but depth
extern const char* const kSolidShadowFragment;  ///< depth of solids minus cut-away faces
extern const char* const kFullscreenVertex;
extern const char* const kSkyFragment;
extern const char* const kGroundFragment;
extern const char* const kSolidFragment;
extern const char* const kWaterBufferFragment;  ///< fluid normals, coverage and depth
extern const char* const kWaterMaskFragment;    ///< copy opaque image, water texels into depth
extern const char* const kWaterShadeFragment;   ///< water shading and composite, water texels only
extern const char* const kToneMapFragment;      ///< filmic curve, sRGB, supersample filter
extern const char* const kSphereVertex;    ///< instanced impostor quads
extern const char* const kSphereFragment;  ///< ray-cast spheres, speed colour ramp
extern const char* const kSphereShadowFragment;

} // namespace cascade::render::shaders
