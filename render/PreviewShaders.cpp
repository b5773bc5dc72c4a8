#include "render/PreviewShaders.h"

namespace cascade::render::shaders {

// Shared by the lit fragment shaders. Lights: index 0 is the key light, the
// one that casts shadows. uLightVector is the direction towards a directional
// light or the position of a point light.
const char* const kCommon = R"(
uniform vec3 uCameraPosition;
uniform int uLightCount;
uniform vec3 uLightVector[4];
uniform int uLightIsPoint[4];
uniform vec3 uLightRadiance[4];
uniform float uLightReference[4];   // point lights: squared reference distance
uniform sampler2DShadow uShadowMap;       // solids and particles
uniform sampler2DShadow uWaterShadowMap;  // the fluid surface
uniform int uWaterShadows;
uniform mat4 uShadowMatrix;         // world -> shadow texture [0,1]^3
uniform float uShadowTexel;
uniform float uShadowBias;
uniform vec3 uSunDirection;         // towards the key light, for the sky
uniform vec3 uSunColor;
uniform int uDrawSky;
uniform vec3 uBackground;
uniform vec3 uStageCenter;
uniform float uStageRadius;
uniform float uGroundHeight;

// Procedural sky: a zenith-to-horizon gradient, a hazy band at the horizon,
// the sun's disk and glow; below the horizon the distant ground haze.
vec3 horizonHaze() { return vec3(0.62, 0.68, 0.74); }
vec3 skyColor(vec3 direction) {
  if (uDrawSky == 0) return uBackground;
  vec3 d = normalize(direction);
  float up = d.z;
  vec3 zenith = vec3(0.09, 0.22, 0.52);
  vec3 horizon = vec3(0.58, 0.70, 0.84);
  vec3 color;
  if (up >= 0.0) {
    color = mix(horizon, zenith, pow(up, 0.55));
    // soft clouds: a few smooth bands of sines projected on a sky dome
    vec2 q = d.xy / (up + 0.25) * 1.7;
    float cloud = sin(q.x * 1.3 + sin(q.y * 0.9)) * sin(q.y * 1.7 + 0.6 * sin(q.x * 1.1))
                + 0.5 * sin(q.x * 3.1 + q.y * 2.3) * sin(q.y * 2.9 - q.x * 1.4);
    cloud = smoothstep(0.35, 1.1, cloud) * smoothstep(0.0, 0.25, up);
    color = mix(color, vec3(0.92, 0.93, 0.95), 0.55 * cloud);
  } else {
    color = mix(horizonHaze(), vec3(0.33, 0.32, 0.30), 1.0 - exp(up * 6.0));
  }
  float sun = max(dot(d, uSunDirection), 0.0);
  color += uSunColor * (12.0 * pow(sun, 2000.0) + 0.25 * pow(sun, 24.0) + 0.08 * pow(sun, 4.0));
  return color;
}

// Hemisphere ambient: sky from above, ground bounce from below.
vec3 ambientLight(vec3 n) {
  vec3 sky = uDrawSky != 0 ? vec3(0.36, 0.42, 0.52) : uBackground * 0.6;
  vec3 ground = vec3(0.16, 0.15, 0.13);
  return mix(ground, sky, 0.5 + 0.5 * n.z);
}

// Percentage-closer filtering (Reeves et al. 1987): one hardware-compared
// bilinear lookup, i.e. a 2x2-texel tent (more taps cost llvmpipe ~10 % of a
// still for little visible gain at 2048^2).
float filteredShadow(sampler2DShadow map, vec3 s) {
  return texture(map, vec3(s.xy, s.z - uShadowBias));
}

// Key light visibility: opaque casters block it, water lets 45 % through
// (`withWater` false: the water does not shadow itself).
float keyLightVisibility(vec3 p, vec3 n, bool withWater) {
  vec4 s = uShadowMatrix * vec4(p + n * uShadowTexel * 1.5 * uStageRadius, 1.0);
  s.xyz /= s.w;
  if (any(lessThan(s.xyz, vec3(0.0))) || any(greaterThan(s.xyz, vec3(1.0)))) return 1.0;
  float solid = filteredShadow(uShadowMap, s.xyz);
  float water = withWater && uWaterShadows != 0 ? filteredShadow(uWaterShadowMap, s.xyz) : 1.0;
  return solid * (1.0 - 0.55 * (1.0 - water));
}
float shadowFactor(vec3 p, vec3 n) { return keyLightVisibility(p, n, true); }

vec3 lightDirection(int i, vec3 p, out vec3 radiance) {
  if (uLightIsPoint[i] != 0) {
    vec3 toLight = uLightVector[i] - p;
    float distance2 = max(dot(toLight, toLight), 1e-8);
    radiance = uLightRadiance[i] * uLightReference[i] / distance2;
    return toLight * inversesqrt(distance2);
  }
  radiance = uLightRadiance[i];
  return uLightVector[i];
}

// Diffuse + soft specular surface lit by all lights (key light shadowed).
vec3 shadeSurface(vec3 p, vec3 n, vec3 albedo, float specular, float shininess) {
  vec3 v = normalize(uCameraPosition - p);
  if (dot(n, v) < 0.0) n = -n;  // two-sided
  vec3 color = albedo * ambientLight(n);
  float shadow = uLightCount > 0 ? shadowFactor(p, n) : 1.0;
  for (int i = 0; i < uLightCount; ++i) {
    vec3 radiance;
    vec3 l = lightDirection(i, p, radiance);
    float ndotl = max(dot(n, l), 0.0);
    float visible = i == 0 ? shadow : 1.0;
    float spec = 0.0;
    if (specular > 0.0) {
      vec3 h = normalize(l + v);
      spec = specular * (shininess + 8.0) / 25.1 * pow(max(dot(n, h), 0.0), shininess);
    }
    color += radiance * ndotl * visible * (albedo + spec);
  }
  return color;
}
)";

const char* const kMeshVertex = R"(
layout(location = 0) in vec3 aPosition;
layout(location = 1) in vec3 aNormal;
layout(location = 2) in vec3 aColor;
layout(location = 3) in vec4 aCutaway;
uniform mat4 uViewProjection;
uniform float uNormalSign;
out vec3 vWorld;
out vec3 vNormal;
out vec3 vColor;
out vec4 vCutaway;
void main() {
  vWorld = aPosition;
  vNormal = aNormal * uNormalSign;
  vColor = aColor;
  vCutaway = aCutaway;
  gl_Position = uViewProjection * vec4(aPosition, 1.0);
}
)";

const char* const kDepthVertex = R"(
layout(location = 0) in vec3 aPosition;
uniform mat4 uViewProjection;
void main() { gl_Position = uViewProjection * vec4(aPosition, 1.0); }
)";

const char* const kDepthFragment = R"(
void main() {}
)";

// Solids into the shadow map, minus the faces cut away for the camera (they
// are not drawn, so they cast no shadow either).
const char* const kSolidShadowFragment = R"(
in vec3 vWorld;
in vec3 vNormal;
in vec3 vColor;
in vec4 vCutaway;
uniform vec3 uCameraPosition;
void main() {
  if (vCutaway.w > 0.0) {
    vec3 faceNormal = cross(dFdx(vWorld), dFdy(vWorld));
    if (dot(faceNormal, faceNormal) > 0.0) {
      float cameraSide = dot(faceNormal, uCameraPosition - vWorld);
      float centerSide = dot(faceNormal, vCutaway.xyz - vWorld);
      if (cameraSide * centerSide < 0.0) discard;
    }
  }
}
)";

const char* const kFullscreenVertex = R"(
out vec2 vNdc;
uniform float uFullscreenDepth;  // NDC z: 1 for the sky (far plane), 0 for the water pass
void main() {
  vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  vNdc = corner * 2.0 - 1.0;
  gl_Position = vec4(vNdc, uFullscreenDepth, 1.0);
}
)";

const char* const kSkyFragment = R"(
in vec2 vNdc;
uniform mat4 uInverseViewProjection;
out vec4 fragColor;
void main() {
  vec4 far = uInverseViewProjection * vec4(vNdc, 1.0, 1.0);
  vec3 direction = normalize(far.xyz / far.w - uCameraPosition);
  fragColor = vec4(skyColor(direction), 0.0);
}
)";

// The ground: a large plane just under the stage, a faint checker of
// "nice" tile size, lit and shadowed, fading into the horizon haze.
const char* const kGroundFragment = R"(
in vec3 vWorld;
in vec3 vNormal;
in vec3 vColor;
in vec4 vCutaway;
uniform float uTileSize;
out vec4 fragColor;
void main() {
  vec2 cell = floor(vWorld.xy / uTileSize);
  float checker = mod(cell.x + cell.y, 2.0);
  vec2 fw = fwidth(vWorld.xy / uTileSize);
  float blur = clamp(max(fw.x, fw.y) * 1.5, 0.0, 1.0);  // fade the checker where it would alias
  vec3 albedo = mix(vec3(0.30, 0.29, 0.27), vec3(0.25, 0.24, 0.23), mix(checker, 0.5, blur));
  vec3 color = shadeSurface(vWorld, vec3(0.0, 0.0, 1.0), albedo, 0.0, 1.0);
  float distance = length(vWorld - uCameraPosition) / (14.0 * uStageRadius);
  float fog = 1.0 - exp(-distance * distance);
  color = mix(color, uDrawSky != 0 ? horizonHaze() : uBackground, fog);
  fragColor = vec4(color, 0.0);
}
)";

// Solids: clay-like diffuse with a little specular. Groups marked for
// cutaway (vCutaway.w > 0, e.g. the tank) drop the faces that stand between
// the camera and the group's centre, so the water inside stays visible.
const char* const kSolidFragment = R"(
in vec3 vWorld;
in vec3 vNormal;
in vec3 vColor;
in vec4 vCutaway;
out vec4 fragColor;
void main() {
  vec3 faceNormal = normalize(cross(dFdx(vWorld), dFdy(vWorld)));
  if (vCutaway.w > 0.0) {
    float cameraSide = dot(faceNormal, uCameraPosition - vWorld);
    float centerSide = dot(faceNormal, vCutaway.xyz - vWorld);
    if (cameraSide * centerSide < -1e-12 * uStageRadius * uStageRadius) discard;
  }
  vec3 n = length(vNormal) > 0.0 ? normalize(vNormal) : faceNormal;
  fragColor = vec4(shadeSurface(vWorld, n, vColor, 0.25, 40.0), 1.0);
}
)";

// Fluid front faces into the water buffers: normal with coverage 1, and
// eye-space depth. The buffers hold WATER_SCALE^2 texels per pixel; their
// averages give coverage-weighted normals and depths, so edges stay smooth.
const char* const kWaterBufferFragment = R"(
in vec3 vWorld;
in vec3 vNormal;
in vec3 vColor;
in vec4 vCutaway;
uniform vec3 uCameraPosition;
uniform vec3 uCameraForward;
uniform sampler2D uOpaqueDepth;   // resolved opaque depth (internal resolution)
uniform vec2 uWaterSize;
layout(location = 0) out vec4 waterNormal;
layout(location = 1) out float waterDepth;
void main() {
  if (gl_FragCoord.z > texture(uOpaqueDepth, gl_FragCoord.xy / uWaterSize).r) discard;  // behind a solid
  vec3 n = normalize(vNormal);
  if (!gl_FrontFacing) n = -n;
  waterNormal = vec4(n, 1.0);
  waterDepth = dot(vWorld - uCameraPosition, uCameraForward);
}
)";

// Water texels only (an early depth test against the mask skips the rest):
// the water shaded once per texel from the resolved water buffers and
// composited over the opaque image by its coverage.
//  - Schlick's Fresnel (F0 = 0.02) mixes the sky's reflection with the
//    refracted opaque image (screen-space offset by the view-space normal);
//  - Beer-Lambert absorption over the thickness between the front face and
//    the nearer of the back face and the opaque surface behind, with
//    in-scattered deep-water colour;
//  - normalised Blinn-Phong sun glints, shadowed by the key light.
const char* const kWaterShadeFragment = R"(
uniform sampler2D uOpaqueColor;
uniform sampler2D uOpaqueDepth;
uniform sampler2D uBackDepth;
uniform sampler2D uWaterNormal;
uniform sampler2D uWaterDepth;
uniform int uHasWater;
uniform vec2 uInternalSize;
uniform vec2 uDepthRange;          // near, far
uniform mat4 uView;
uniform mat4 uInverseViewProjection;
uniform vec3 uCameraForward;
uniform vec3 uDeepWaterColor;
uniform vec3 uAbsorption;          // per absorption length
uniform float uAbsorptionLength;   // m
uniform float uRefraction;         // screen-space offset scale
out vec4 fragColor;

float eyeDepth(float depth) {
  float n = uDepthRange.x, f = uDepthRange.y;
  float z = depth * 2.0 - 1.0;
  return 2.0 * n * f / (f + n - z * (f - n));
}

vec3 shadeWater(vec2 uv, vec3 n, float front) {
  vec4 far = uInverseViewProjection * vec4(uv * 2.0 - 1.0, 1.0, 1.0);
  vec3 ray = normalize(far.xyz / far.w - uCameraPosition);
  vec3 p = uCameraPosition + ray * (front / max(dot(ray, uCameraForward), 1e-6));
  vec3 v = -ray;
  float ndotv = dot(n, v);
  if (ndotv < 0.0) { n = normalize(n - 1.01 * ndotv * v); ndotv = dot(n, v); }  // grazing normals
  float back = eyeDepth(texture(uBackDepth, uv).r);
  float opaque = eyeDepth(texture(uOpaqueDepth, uv).r);
  float thickness = max(min(back, opaque) - front, 0.0);
  float relative = thickness / uAbsorptionLength;

  // Refraction: shift the lookup of what lies behind by the view-space
  // normal, more for thicker water; reject samples in front of the water.
  vec3 viewNormal = mat3(uView) * n;
  vec2 offset = -viewNormal.xy * uRefraction * clamp(relative * 4.0, 0.0, 1.0);
  vec2 uvRefracted = clamp(uv + offset, vec2(0.0), vec2(1.0));
  if (eyeDepth(texture(uOpaqueDepth, uvRefracted).r) < front) uvRefracted = uv;
  vec3 behind = texture(uOpaqueColor, uvRefracted).rgb;

  vec3 transmittance = exp(-uAbsorption * relative);
  float shadow = uLightCount > 0 ? keyLightVisibility(p, n, false) : 1.0;
  vec3 keyRadiance = vec3(0.0);
  if (uLightCount > 0) { vec3 r; lightDirection(0, p, r); keyRadiance = r; }
  vec3 scatter = uDeepWaterColor * (ambientLight(vec3(0.0, 0.0, 1.0)) * 1.6 + keyRadiance * (0.4 + 0.6 * shadow));
  vec3 refracted = behind * transmittance + scatter * (1.0 - transmittance);

  vec3 r = reflect(-v, n);
  vec3 reflected = skyColor(r);
  if (r.z < 0.0) reflected = mix(reflected, ambientLight(vec3(0.0, 0.0, -1.0)) * 1.2, 0.5);
  float fresnel = 0.02 + 0.98 * pow(1.0 - clamp(ndotv, 0.0, 1.0), 5.0);
  vec3 color = mix(refracted, reflected, fresnel);

  for (int i = 0; i < uLightCount; ++i) {
    vec3 radiance;
    vec3 l = lightDirection(i, p, radiance);
    float ndotl = max(dot(n, l), 0.0);
    vec3 h = normalize(l + v);
    float ndoth = max(dot(n, h), 0.0);
    float fh = 0.02 + 0.98 * pow(1.0 - max(dot(h, v), 0.0), 5.0);
    float lobe = (600.0 + 8.0) / 25.1 * pow(ndoth, 600.0) + 0.08 * (40.0 + 8.0) / 25.1 * pow(ndoth, 40.0);
    color += radiance * ndotl * fh * lobe * (i == 0 ? shadow : 1.0);
  }
  return color;
}

void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
  vec4 opaque = texelFetch(uOpaqueColor, texel, 0);
  vec4 water = vec4(0.0);
  float depthSum = 0.0;
  for (int j = 0; j < WATER_SCALE; ++j)
    for (int i = 0; i < WATER_SCALE; ++i) {
      ivec2 sub = texel * WATER_SCALE + ivec2(i, j);
      water += texelFetch(uWaterNormal, sub, 0);
      depthSum += texelFetch(uWaterDepth, sub, 0).r;
    }
  float coverage = clamp(water.w / float(WATER_SCALE * WATER_SCALE), 0.0, 1.0);
  vec3 color = opaque.rgb;
  if (coverage > 0.0 && dot(water.xyz, water.xyz) > 1e-12) {
    float front = depthSum / water.w;
    vec2 uv = (vec2(texel) + 0.5) / uInternalSize;
    color = mix(color, shadeWater(uv, normalize(water.xyz), front), coverage);
  }
  fragColor = vec4(color, opaque.a + coverage * (1.0 - opaque.a));
}
)";

// Copies the opaque image into the composite target and marks water texels
// in the depth buffer (0 water, 1 none) for the early depth test of the
// water shading pass.
const char* const kWaterMaskFragment = R"(
uniform sampler2D uOpaqueColor;
uniform sampler2D uWaterNormal;
out vec4 fragColor;
void main() {
  ivec2 texel = ivec2(gl_FragCoord.xy);
  fragColor = texelFetch(uOpaqueColor, texel, 0);
  float coverage = 0.0;
  for (int j = 0; j < WATER_SCALE; ++j)
    for (int i = 0; i < WATER_SCALE; ++i)
      coverage += texelFetch(uWaterNormal, texel * WATER_SCALE + ivec2(i, j), 0).w;
  gl_FragDepth = coverage > 0.0 ? 0.0 : 1.0;
}
)";

// Resolved HDR -> filmic curve (Narkowicz 2015 ACES fit) -> sRGB, averaging
// SUPERSAMPLE^2 source texels per output pixel.
const char* const kToneMapFragment = R"(
uniform sampler2D uHdr;
uniform float uExposure;
const int uSupersample = SUPERSAMPLE;
out vec4 fragColor;
vec3 filmic(vec3 x) {
  x *= uExposure;
  return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0);
}
vec3 encodeSrgb(vec3 c) {
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
void main() {
  ivec2 base = ivec2(gl_FragCoord.xy) * uSupersample;
  vec4 sum = vec4(0.0);
  for (int j = 0; j < uSupersample; ++j)
    for (int i = 0; i < uSupersample; ++i) {
      vec4 texel = texelFetch(uHdr, base + ivec2(i, j), 0);
      sum += vec4(filmic(max(texel.rgb, vec3(0.0))), texel.a);
    }
  sum /= float(uSupersample * uSupersample);
  fragColor = vec4(encodeSrgb(sum.rgb), clamp(sum.a, 0.0, 1.0));
}
)";

// One quad per particle, perpendicular to the direction from the eye to the
// sphere's centre, with half-size d r / sqrt(d^2 - r^2): exactly the
// circumscribed square of the sphere's silhouette cone.
const char* const kSphereVertex = R"(
layout(location = 0) in vec4 aSphere;   // centre, speed
uniform mat4 uViewProjection;
uniform vec3 uEye;                      // camera or point-light position
uniform vec3 uAxis;                     // orthographic: direction towards the eye
uniform int uOrthographic;
uniform float uRadius;
out vec3 vWorld;
out vec2 vCorner;
flat out vec4 vSphere;
void main() {
  vec2 corner = vec2(float(gl_VertexID & 1), float((gl_VertexID >> 1) & 1)) * 2.0 - 1.0;
  vec3 center = aSphere.xyz;
  vec3 axis;
  float halfSize = uRadius;
  if (uOrthographic != 0) {
    axis = uAxis;
  } else {
    vec3 toEye = uEye - center;
    float d = length(toEye);
    axis = toEye / max(d, 1e-20);
    halfSize = d > uRadius * 1.0001 ? d * uRadius / sqrt(d * d - uRadius * uRadius) : 0.0;
  }
  vec3 helper = abs(axis.z) < 0.9 ? vec3(0.0, 0.0, 1.0) : vec3(1.0, 0.0, 0.0);
  vec3 s = normalize(cross(helper, axis));
  vec3 t = cross(axis, s);
  vWorld = center + (s * corner.x + t * corner.y) * halfSize;
  vCorner = corner;
  vSphere = aSphere;
  gl_Position = uViewProjection * vec4(vWorld, 1.0);
}
)";

const char* const kSphereFragment = R"(
in vec3 vWorld;
in vec2 vCorner;
flat in vec4 vSphere;
uniform mat4 uViewProjection;
uniform float uRadius;
uniform float uSpeedScale;
uniform float uWhite;                   // 1: whitewater (white), 0: coloured by speed
out vec4 fragColor;

vec3 speedRamp(float t) {   // deep blue, cyan, pale, white
  vec3 c0 = vec3(0.02, 0.08, 0.45), c1 = vec3(0.03, 0.45, 0.80), c2 = vec3(0.45, 0.85, 0.95), c3 = vec3(1.0);
  if (t < 0.4) return mix(c0, c1, t / 0.4);
  if (t < 0.8) return mix(c1, c2, (t - 0.4) / 0.4);
  return mix(c2, c3, (t - 0.8) / 0.2);
}

void main() {
  // Ray from the eye through this fragment against the sphere (exact silhouette and depth).
  vec3 direction = normalize(vWorld - uCameraPosition);
  vec3 oc = uCameraPosition - vSphere.xyz;
  float b = dot(direction, oc);
  float c = dot(oc, oc) - uRadius * uRadius;
  float discriminant = b * b - c;
  if (discriminant < 0.0) discard;
  float t = -b - sqrt(discriminant);
  vec3 hit = uCameraPosition + t * direction;
  vec4 clip = uViewProjection * vec4(hit, 1.0);
  gl_FragDepth = clamp(0.5 * clip.z / clip.w + 0.5, 0.0, 1.0);
  vec3 n = (hit - vSphere.xyz) / uRadius;
  vec3 albedo = mix(speedRamp(clamp(vSphere.w / uSpeedScale, 0.0, 1.0)), vec3(0.9), uWhite);
  fragColor = vec4(shadeSurface(hit, n, albedo, 0.6, 60.0), 1.0);
}
)";

const char* const kSphereShadowFragment = R"(
in vec3 vWorld;
in vec2 vCorner;
flat in vec4 vSphere;
void main() { if (dot(vCorner, vCorner) > 1.0) discard; }
)";

} // namespace cascade::render::shaders
