#include "render/PreviewRenderer.h"

#include "render/PreviewShaders.h"

#define GL_GLEXT_PROTOTYPES 1
#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include "render/OsMesaLibrary.h"  // after the GL headers with their prototypes

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>

namespace cascade::render {

Box3f meshBounds(const TriangleMesh& mesh) {
  Box3f box;  // empty
  for (const auto& v : mesh.vertices) box.extend(v);
  return box;
}

namespace {

// Every GL entry point is fetched from OSMesa itself, so a libGL that some
// other library might load cannot intercept the calls.
#define CASCADE_GL_FUNCTIONS(X)                                                                    \
  X(glGetString) X(glGetIntegerv) X(glGetError) X(glViewport) X(glClear) X(glClearColor)           \
  X(glClearDepth) X(glEnable) X(glDisable) X(glDepthFunc) X(glDepthMask) X(glCullFace)             \
  X(glFrontFace) X(glPolygonOffset) X(glReadPixels) X(glPixelStorei) X(glDrawArrays)               \
  X(glDrawElements) X(glDrawArraysInstanced) X(glGenTextures) X(glDeleteTextures)                  \
  X(glBindTexture) X(glTexImage2D) X(glTexParameteri) X(glActiveTexture) X(glGenFramebuffers)      \
  X(glDeleteFramebuffers) X(glBindFramebuffer) X(glFramebufferTexture2D)                           \
  X(glFramebufferRenderbuffer) X(glCheckFramebufferStatus) X(glGenRenderbuffers)                   \
  X(glDeleteRenderbuffers) X(glBindRenderbuffer) X(glRenderbufferStorageMultisample)               \
  X(glBlitFramebuffer) X(glDrawBuffer) X(glReadBuffer) X(glCreateShader) X(glShaderSource)         \
  X(glCompileShader) X(glGetShaderiv) X(glGetShaderInfoLog) X(glCreateProgram)                     \
  X(glAttachShader) X(glLinkProgram) X(glGetProgramiv) X(glGetProgramInfoLog) X(glDeleteShader)    \
  X(glDeleteProgram) X(glUseProgram) X(glGetUniformLocation) X(glUniform1i) X(glUniform1f)         \
  X(glUniform2f) X(glUniform3f) X(glUniform1iv) X(glUniform1fv) X(glUniform3fv)                    \
  X(glUniformMatrix4fv) X(glGenVertexArrays) X(glDeleteVertexArrays) X(glBindVertexArray)          \
  X(glGenBuffers) X(glDeleteBuffers) X(glBindBuffer) X(glBufferData) X(glVertexAttribPointer)      \
  X(glVertexAttrib3f) X(glVertexAttrib4f) X(glEnableVertexAttribArray)                             \
  X(glDisableVertexAttribArray) X(glVertexAttribDivisor) X(glMinSampleShading) X(glFinish)          \
  X(glDrawBuffers) X(glClearBufferfv)

struct GlFunctions {
#define CASCADE_GL_DECLARE(name) decltype(&::name) name = nullptr;
  CASCADE_GL_FUNCTIONS(CASCADE_GL_DECLARE)
#undef CASCADE_GL_DECLARE

  void load() {
#define CASCADE_GL_LOAD(name)                                                                      \
  name = reinterpret_cast<decltype(&::name)>(osMesa().getProcAddress(#name));                          \
  if (!name) throw std::runtime_error("render: OSMesa lacks " #name);
    CASCADE_GL_FUNCTIONS(CASCADE_GL_LOAD)
#undef CASCADE_GL_LOAD
  }
};

constexpr int kShadowMapSize = 2048;
constexpr int kMaxLights = 4;

struct Program {
  GLuint id = 0;
  std::unordered_map<std::string, GLint> locations;
};

Eigen::Matrix4f lookAt(const Eigen::Vector3f& eye, const Eigen::Vector3f& target,
                       const Eigen::Vector3f& up) {
  Camera camera;
  camera.position = eye;
  camera.target = target;
  camera.up = up;
  return camera.viewMatrix();
}

Eigen::Matrix4f orthographic(float halfWidth, float nearPlane, float farPlane) {
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m(0, 0) = 1.0f / halfWidth;
  m(1, 1) = 1.0f / halfWidth;
  m(2, 2) = -2.0f / (farPlane - nearPlane);
  m(2, 3) = -(farPlane + nearPlane) / (farPlane - nearPlane);
  return m;
}

float niceTile(float length) {
  const float power = std::pow(10.0f, std::floor(std::log10(length)));
  const float ratio = length / power;
  return power * (ratio >= 5 ? 5.0f : ratio >= 2 ? 2.0f : 1.0f);
}

std::string lowercase(std::string text) {
  for (char& c : text) c = char(std::tolower(static_cast<unsigned char>(c)));
  return text;
}

bool contains(const std::string& text, const char* word) { return text.find(word) != std::string::npos; }

// Solid colours by the group's name: tank and ground neutral, slope sandstone,
// obstacles from a small clay palette.
void solidLook(const std::string& groupName, int obstacleIndex, Eigen::Vector3f& color, bool& cutaway) {
  static const Eigen::Vector3f palette[] = {{0.70f, 0.36f, 0.22f}, {0.62f, 0.60f, 0.56f},
                                            {0.42f, 0.48f, 0.58f}, {0.70f, 0.60f, 0.38f}};
  const std::string name = lowercase(groupName);
  cutaway = false;
  if (contains(name, "tank") || contains(name, "container") || contains(name, "domain")) {
    color = {0.36f, 0.37f, 0.38f};
    cutaway = true;
  } else if (contains(name, "ground") || contains(name, "floor") || contains(name, "plane")) {
    color = {0.50f, 0.49f, 0.46f};
  } else if (contains(name, "slope") || contains(name, "ramp")) {
    color = {0.56f, 0.49f, 0.39f};
  } else {
    color = palette[obstacleIndex % 4];
  }
}

} // namespace

struct PreviewRenderer::Impl {
  int width = 0, height = 0;
  int multisamples = 1, supersample = 1;
  int internalWidth = 0, internalHeight = 0;
  RenderLook look;
  OSMesaContext context = nullptr;
  std::vector<unsigned char> dummyBuffer = std::vector<unsigned char>(16 * 16 * 4);
  GlFunctions gl;
  std::string description;

  Program depthProgram, solidShadowProgram, skyProgram, groundProgram, solidProgram, waterBufferProgram, waterMaskProgram,
      waterShadeProgram, sphereProgram, sphereShadowProgram, toneMapProgram;

  GLuint emptyVao = 0, fluidVao = 0, solidsVao = 0, groundVao = 0, sphereVao = 0, whitewaterVao = 0;
  GLuint whitewaterBuffer = 0;
  GLuint fluidPositions = 0, fluidNormals = 0, fluidIndices = 0, solidsBuffer = 0, groundBuffer = 0,
         sphereBuffer = 0;
  std::size_t fluidIndexCount = 0, solidsVertexCount = 0, sphereCount = 0;
  const TriangleMesh* solidsKey = nullptr;
  std::size_t solidsKeyTriangles = 0, solidsKeyVertices = 0;
  std::uint64_t solidsKeyHash = 0;

  GLuint shadowFbo = 0, shadowTexture = 0, waterShadowFbo = 0, waterShadowTexture = 0;
  GLuint msFbo = 0, msColor = 0, msDepth = 0;
  GLuint resolveFbo = 0, resolveColor = 0, resolveDepth = 0;
  // Water buffers, single-sampled at waterScale x the internal resolution
  // (llvmpipe rasterises a million tiny triangles far faster without MSAA;
  // a 2x2 grid of texels per pixel gives the same 4 coverage samples).
  int waterScale = 1;
  GLuint waterFbo = 0, waterNormal = 0, waterDepth = 0, waterDepthBuffer = 0;
  GLuint backFbo = 0, backDepth = 0;
  GLuint outFbo = 0, outColor = 0;
  GLuint compositeFbo = 0, compositeColor = 0, compositeMask = 0;

  GLuint colorTexture(GLenum format, int w, int h, bool linear);
  Impl(int w, int h, int samples, RenderLook renderLook);
  ~Impl();
  void makeCurrent();
  GLuint compile(GLenum type, const std::string& source);
  Program link(const char* vertex, const char* fragment, bool common);
  GLint location(Program& program, const char* name);
  void setInt(Program& p, const char* name, int value) { gl.glUniform1i(location(p, name), value); }
  void setFloat(Program& p, const char* name, float value) { gl.glUniform1f(location(p, name), value); }
  void setVec2(Program& p, const char* name, float x, float y) { gl.glUniform2f(location(p, name), x, y); }
  void setVec3(Program& p, const char* name, const Eigen::Vector3f& v) {
    gl.glUniform3f(location(p, name), v.x(), v.y(), v.z());
  }
  void setMatrix(Program& p, const char* name, const Eigen::Matrix4f& m) {
    gl.glUniformMatrix4fv(location(p, name), 1, GL_FALSE, m.data());  // Eigen is column-major
  }
  GLuint depthTexture(int w, int h, bool compare);
  void createTargets();
  void checkFramebuffer(const char* what);
  /// A framebuffer with only `depth` attached (no colour), checked; `what` names it in errors.
  GLuint depthOnlyFramebuffer(GLuint depth, const char* what);
  void uploadFluid(const TriangleMesh& mesh, float& normalSign, bool& clockwise);
  void uploadSolids(const TriangleMesh& mesh);
  void uploadSpheres(const ParticleSpheres& particles);
  Image render(const FrameScene& scene);
};

PreviewRenderer::Impl::Impl(int w, int h, int samples, RenderLook renderLook)
    : width(w), height(h), look(std::move(renderLook)) {
  if (w <= 0 || h <= 0 || w > 8192 || h > 8192)
    throw std::invalid_argument("render: image size must be within 1..8192 (got " +
                                std::to_string(w) + "x" + std::to_string(h) + ")");
  // llvmpipe reads its thread count when the first context is made: default
  // to one rasteriser thread per hardware thread unless the user chose.
  static std::once_flag threadsOnce;
  std::call_once(threadsOnce, [] {
    const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
    ::setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 0);
  });
  const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0, OSMESA_STENCIL_BITS, 0,
                            OSMESA_ACCUM_BITS, 0, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
  context = osMesa().createContextAttribs(attributes, nullptr);
  if (!context)
    throw std::runtime_error("render: cannot create an OSMesa OpenGL 3.3 core context (Mesa llvmpipe)");
  makeCurrent();
  gl.load();
  description = std::string(reinterpret_cast<const char*>(gl.glGetString(GL_VERSION))) + ", " +
                reinterpret_cast<const char*>(gl.glGetString(GL_RENDERER));
  GLint maxSamples = 1;
  gl.glGetIntegerv(GL_MAX_SAMPLES, &maxSamples);
  samples = std::max(1, samples);
  multisamples = std::min(samples, std::max(1, int(maxSamples)));
  // Supersampling (2x2) only up to 2560x1440 output, the 2x water buffers only
  // up to 4K internal: beyond that the targets would need gigabytes.
  const std::size_t pixels = std::size_t(width) * std::size_t(height);
  supersample = samples > multisamples && pixels <= std::size_t(2560) * 1440 ? 2 : 1;
  internalWidth = width * supersample;
  internalHeight = height * supersample;

  using namespace shaders;
  depthProgram = link(kDepthVertex, kDepthFragment, false);
  solidShadowProgram = link(kMeshVertex, kSolidShadowFragment, false);
  skyProgram = link(kFullscreenVertex, kSkyFragment, true);
  groundProgram = link(kMeshVertex, kGroundFragment, true);
  solidProgram = link(kMeshVertex, kSolidFragment, true);
  waterBufferProgram = link(kMeshVertex, kWaterBufferFragment, false);
  sphereProgram = link(kSphereVertex, kSphereFragment, true);
  sphereShadowProgram = link(kSphereVertex, kSphereShadowFragment, false);
  waterScale = multisamples > 1 && supersample == 1 && pixels <= std::size_t(3840) * 2160 ? 2 : 1;
  const std::string waterDefine = "#define WATER_SCALE " + std::to_string(waterScale) + "\n";
  waterMaskProgram = link(kFullscreenVertex, (waterDefine + kWaterMaskFragment).c_str(), false);
  waterShadeProgram = link(kFullscreenVertex, (waterDefine + kWaterShadeFragment).c_str(), true);
  toneMapProgram = link(kFullscreenVertex,
                        ("#define SUPERSAMPLE " + std::to_string(supersample) + "\n" + kToneMapFragment).c_str(), false);

  gl.glGenVertexArrays(1, &emptyVao);
  gl.glGenVertexArrays(1, &fluidVao);
  gl.glGenVertexArrays(1, &solidsVao);
  gl.glGenVertexArrays(1, &groundVao);
  gl.glGenVertexArrays(1, &sphereVao);
  gl.glGenVertexArrays(1, &whitewaterVao);
  gl.glGenBuffers(1, &whitewaterBuffer);
  GLuint buffers[6];
  gl.glGenBuffers(6, buffers);
  fluidPositions = buffers[0];
  fluidNormals = buffers[1];
  fluidIndices = buffers[2];
  solidsBuffer = buffers[3];
  groundBuffer = buffers[4];
  sphereBuffer = buffers[5];

  // Vertex layouts. Locations 2 (colour) and 3 (cutaway) are constant
  // attributes where no array feeds them.
  gl.glBindVertexArray(fluidVao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, fluidPositions);
  gl.glEnableVertexAttribArray(0);
  gl.glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  gl.glBindBuffer(GL_ARRAY_BUFFER, fluidNormals);
  gl.glEnableVertexAttribArray(1);
  gl.glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  gl.glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, fluidIndices);

  gl.glBindVertexArray(solidsVao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, solidsBuffer);
  const GLsizei stride = 13 * sizeof(float);
  for (int a = 0; a < 4; ++a) gl.glEnableVertexAttribArray(GLuint(a));
  gl.glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(0));
  gl.glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(3 * sizeof(float)));
  gl.glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(6 * sizeof(float)));
  gl.glVertexAttribPointer(3, 4, GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(9 * sizeof(float)));

  gl.glBindVertexArray(groundVao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, groundBuffer);
  gl.glEnableVertexAttribArray(0);
  gl.glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);

  gl.glBindVertexArray(sphereVao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, sphereBuffer);
  gl.glEnableVertexAttribArray(0);
  gl.glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
  gl.glVertexAttribDivisor(0, 1);
  gl.glBindVertexArray(whitewaterVao);
  gl.glBindBuffer(GL_ARRAY_BUFFER, whitewaterBuffer);
  gl.glEnableVertexAttribArray(0);
  gl.glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
  gl.glVertexAttribDivisor(0, 1);
  gl.glBindVertexArray(0);

  createTargets();
}

PreviewRenderer::Impl::~Impl() {
  if (context) osMesa().destroyContext(context);  // frees every GL object of the context
}

void PreviewRenderer::Impl::makeCurrent() {
  if (!osMesa().makeCurrent(context, dummyBuffer.data(), GL_UNSIGNED_BYTE, 16, 16))
    throw std::runtime_error("render: OSMesaMakeCurrent failed");
}

GLuint PreviewRenderer::Impl::compile(GLenum type, const std::string& source) {
  const GLuint shader = gl.glCreateShader(type);
  const char* text = source.c_str();
  gl.glShaderSource(shader, 1, &text, nullptr);
  gl.glCompileShader(shader);
  GLint ok = GL_FALSE;
  gl.glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096] = {0};
    gl.glGetShaderInfoLog(shader, sizeof log - 1, nullptr, log);
    throw std::runtime_error(std::string("render: shader compilation failed: ") + log);
  }
  return shader;
}

Program PreviewRenderer::Impl::link(const char* vertex, const char* fragment,
                                                           bool common) {
  const std::string header = "#version 330 core\n";
  const GLuint vs = compile(GL_VERTEX_SHADER, header + vertex);
  const GLuint fs = compile(GL_FRAGMENT_SHADER, header + (common ? shaders::kCommon : "") + fragment);
  Program program;
  program.id = gl.glCreateProgram();
  gl.glAttachShader(program.id, vs);
  gl.glAttachShader(program.id, fs);
  gl.glLinkProgram(program.id);
  gl.glDeleteShader(vs);
  gl.glDeleteShader(fs);
  GLint ok = GL_FALSE;
  gl.glGetProgramiv(program.id, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096] = {0};
    gl.glGetProgramInfoLog(program.id, sizeof log - 1, nullptr, log);
    throw std::runtime_error(std::string("render: shader link failed: ") + log);
  }
  return program;
}

GLint PreviewRenderer::Impl::location(Program& program, const char* name) {
  auto found = program.locations.find(name);
  if (found != program.locations.end()) return found->second;
  const GLint where = gl.glGetUniformLocation(program.id, name);
  program.locations.emplace(name, where);
  return where;
}

GLuint PreviewRenderer::Impl::depthTexture(int w, int h, bool compare) {
  GLuint texture = 0;
  gl.glGenTextures(1, &texture);
  gl.glBindTexture(GL_TEXTURE_2D, texture);
  gl.glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, w, h, 0, GL_DEPTH_COMPONENT, GL_UNSIGNED_INT, nullptr);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, compare ? GL_LINEAR : GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, compare ? GL_LINEAR : GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  if (compare) {
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  }
  return texture;
}

GLuint PreviewRenderer::Impl::colorTexture(GLenum format, int w, int h, bool linear) {
  GLuint texture = 0;
  gl.glGenTextures(1, &texture);
  gl.glBindTexture(GL_TEXTURE_2D, texture);
  const GLenum layout = format == GL_R32F ? GL_RED : GL_RGBA;
  const GLenum type = format == GL_RGBA8 ? GL_UNSIGNED_BYTE : GL_FLOAT;
  gl.glTexImage2D(GL_TEXTURE_2D, 0, GLint(format), w, h, 0, layout, type, nullptr);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, linear ? GL_LINEAR : GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, linear ? GL_LINEAR : GL_NEAREST);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  gl.glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  return texture;
}

void PreviewRenderer::Impl::checkFramebuffer(const char* what) {
  const GLenum status = gl.glCheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw std::runtime_error(std::string("render: ") + what + " framebuffer incomplete (status 0x" +
                             [&] { char b[16]; std::snprintf(b, sizeof b, "%x", status); return std::string(b); }() + ")");
}

GLuint PreviewRenderer::Impl::depthOnlyFramebuffer(GLuint depth, const char* what) {
  GLuint fbo = 0;
  gl.glGenFramebuffers(1, &fbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, fbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, depth, 0);
  gl.glDrawBuffer(GL_NONE);
  gl.glReadBuffer(GL_NONE);
  checkFramebuffer(what);
  return fbo;
}

void PreviewRenderer::Impl::createTargets() {
  // Shadow map.
  shadowTexture = depthTexture(kShadowMapSize, kShadowMapSize, true);
  shadowFbo = depthOnlyFramebuffer(shadowTexture, "shadow");
  waterShadowTexture = depthTexture(kShadowMapSize, kShadowMapSize, true);
  waterShadowFbo = depthOnlyFramebuffer(waterShadowTexture, "water shadow");

  // Multisampled HDR scene: 0 opaque colour (alpha = coverage), 1 water
  // normal and coverage, 2 water eye depth; and depth.
  const int msSamples = multisamples > 1 ? multisamples : 0;
  auto renderbuffer = [&](GLenum format) {
    GLuint buffer = 0;
    gl.glGenRenderbuffers(1, &buffer);
    gl.glBindRenderbuffer(GL_RENDERBUFFER, buffer);
    gl.glRenderbufferStorageMultisample(GL_RENDERBUFFER, msSamples, format, internalWidth, internalHeight);
    return buffer;
  };
  msColor = renderbuffer(GL_RGBA16F);
  msDepth = renderbuffer(GL_DEPTH_COMPONENT24);
  gl.glGenFramebuffers(1, &msFbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, msFbo);
  gl.glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msColor);
  gl.glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msDepth);
  checkFramebuffer("multisample");

  // Resolved colour and depth of the opaque image.
  resolveColor = colorTexture(GL_RGBA16F, internalWidth, internalHeight, true);
  resolveDepth = depthTexture(internalWidth, internalHeight, false);
  gl.glGenFramebuffers(1, &resolveFbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, resolveFbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, resolveColor, 0);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, resolveDepth, 0);
  checkFramebuffer("resolve");

  // Water buffers: 0 normal with coverage 1, 1 eye depth.
  const int waterWidth = internalWidth * waterScale, waterHeight = internalHeight * waterScale;
  waterNormal = colorTexture(GL_RGBA16F, waterWidth, waterHeight, false);
  waterDepth = colorTexture(GL_R32F, waterWidth, waterHeight, false);
  gl.glGenRenderbuffers(1, &waterDepthBuffer);
  gl.glBindRenderbuffer(GL_RENDERBUFFER, waterDepthBuffer);
  gl.glRenderbufferStorageMultisample(GL_RENDERBUFFER, 0, GL_DEPTH_COMPONENT24, waterWidth, waterHeight);
  gl.glGenFramebuffers(1, &waterFbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, waterFbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, waterNormal, 0);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT1, GL_TEXTURE_2D, waterDepth, 0);
  gl.glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, waterDepthBuffer);
  {
    const GLenum buffers[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    gl.glDrawBuffers(2, buffers);
  }
  checkFramebuffer("water");

  // The fluid's nearest back faces.
  backDepth = depthTexture(internalWidth, internalHeight, false);
  backFbo = depthOnlyFramebuffer(backDepth, "back-face");

  // Opaque image with the water composited; depth holds the water mask.
  compositeColor = colorTexture(GL_RGBA16F, internalWidth, internalHeight, false);
  gl.glGenRenderbuffers(1, &compositeMask);
  gl.glBindRenderbuffer(GL_RENDERBUFFER, compositeMask);
  gl.glRenderbufferStorageMultisample(GL_RENDERBUFFER, 0, GL_DEPTH_COMPONENT24, internalWidth, internalHeight);
  gl.glGenFramebuffers(1, &compositeFbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, compositeFbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, compositeColor, 0);
  gl.glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, compositeMask);
  checkFramebuffer("composite");

  // 8-bit sRGB output.
  outColor = colorTexture(GL_RGBA8, width, height, false);
  gl.glGenFramebuffers(1, &outFbo);
  gl.glBindFramebuffer(GL_FRAMEBUFFER, outFbo);
  gl.glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, outColor, 0);
  checkFramebuffer("output");
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

void PreviewRenderer::Impl::uploadFluid(const TriangleMesh& mesh, float& normalSign, bool& clockwise) {
  const std::size_t n = mesh.vertices.size();
  for (const auto& t : mesh.triangles)
    if (t[0] >= n || t[1] >= n || t[2] >= n)
      throw std::invalid_argument("render: fluid mesh has a vertex index out of range");
  // Orientation from the signed volume (divergence theorem): negative means
  // the triangles wind clockwise seen from outside.
  double volume = 0;
  for (const auto& t : mesh.triangles) {
    const Eigen::Vector3d a = mesh.vertices[t[0]].cast<double>(), b = mesh.vertices[t[1]].cast<double>(),
                          c = mesh.vertices[t[2]].cast<double>();
    volume += a.dot(b.cross(c));
  }
  clockwise = volume < 0;
  std::vector<Eigen::Vector3f> computed;
  const std::vector<Eigen::Vector3f>* normals = &mesh.normals;
  if (mesh.normals.size() != n) {
    computed.assign(n, Eigen::Vector3f::Zero());
    for (const auto& t : mesh.triangles) {
      const Eigen::Vector3f area = (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                       .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      for (int k = 0; k < 3; ++k) computed[t[k]] += area;
    }
    for (auto& normal : computed) {
      const float length = normal.norm();
      if (length > 0) normal /= length;
    }
    normals = &computed;
    normalSign = clockwise ? -1.0f : 1.0f;
  } else {
    // Do the given normals agree with the winding? Sample the triangles.
    double agreement = 0;
    const std::size_t step = std::max<std::size_t>(1, mesh.triangles.size() / 4096);
    for (std::size_t i = 0; i < mesh.triangles.size(); i += step) {
      const auto& t = mesh.triangles[i];
      const Eigen::Vector3f area = (mesh.vertices[t[1]] - mesh.vertices[t[0]])
                                       .cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      agreement += area.dot(mesh.normals[t[0]] + mesh.normals[t[1]] + mesh.normals[t[2]]);
    }
    // Normals point outward if they agree with a counter-clockwise winding.
    normalSign = ((agreement >= 0) == !clockwise) ? 1.0f : -1.0f;
  }
  gl.glBindBuffer(GL_ARRAY_BUFFER, fluidPositions);
  gl.glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(n * sizeof(Eigen::Vector3f)), mesh.vertices.data(), GL_STREAM_DRAW);
  gl.glBindBuffer(GL_ARRAY_BUFFER, fluidNormals);
  gl.glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(n * sizeof(Eigen::Vector3f)), normals->data(), GL_STREAM_DRAW);
  gl.glBindVertexArray(fluidVao);
  gl.glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, fluidIndices);
  gl.glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(mesh.triangles.size() * sizeof(mesh.triangles[0])),
                  mesh.triangles.data(), GL_STREAM_DRAW);
  gl.glBindVertexArray(0);
  fluidIndexCount = mesh.triangles.size() * 3;
}

void PreviewRenderer::Impl::uploadSolids(const TriangleMesh& mesh) {
  // Solids that move (a frame's own solids.NNNN.obj) may reuse the last frame's storage:
  // the key is the vertex data itself (FNV-1a over its bytes), not the address.
  std::uint64_t hash = 1469598103934665603ULL;
  const auto* bytes = reinterpret_cast<const unsigned char*>(mesh.vertices.data());
  for (std::size_t k = 0; k < mesh.vertices.size() * sizeof(mesh.vertices[0]); ++k) hash = (hash ^ bytes[k]) * 1099511628211ULL;
  const bool same = solidsKey == &mesh && solidsKeyTriangles == mesh.triangles.size() &&
                    solidsKeyVertices == mesh.vertices.size() && solidsKeyHash == hash;
  if (same) return;
  const std::size_t n = mesh.vertices.size();
  for (const auto& t : mesh.triangles)
    if (t[0] >= n || t[1] >= n || t[2] >= n)
      throw std::invalid_argument("render: solid mesh has a vertex index out of range");
  // Groups cover [begin, end) triangle ranges; triangles outside any group form one more.
  std::vector<TriangleMesh::Group> groups = mesh.groups;
  if (groups.empty()) groups.push_back({"solid", 0, mesh.triangles.size()});
  std::vector<float> data;
  data.reserve(mesh.triangles.size() * 3 * 13);
  const bool smooth = mesh.normals.size() == n;
  int obstacleIndex = 0;
  for (const auto& group : groups) {
    Eigen::Vector3f color;
    bool cutaway = false;
    solidLook(group.name, obstacleIndex, color, cutaway);
    const std::string name = lowercase(group.name);
    if (!cutaway && !contains(name, "ground") && !contains(name, "floor") && !contains(name, "slope") &&
        !contains(name, "ramp") && !contains(name, "plane"))
      ++obstacleIndex;
    Box3f box;
    const std::size_t end = std::min(group.end, mesh.triangles.size());
    for (std::size_t i = group.begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) box.extend(mesh.vertices[mesh.triangles[i][k]]);
    const Eigen::Vector3f center = box.isEmpty() ? Eigen::Vector3f(Eigen::Vector3f::Zero()) : Eigen::Vector3f(box.center());
    for (std::size_t i = group.begin; i < end; ++i) {
      const auto& t = mesh.triangles[i];
      Eigen::Vector3f face = (mesh.vertices[t[1]] - mesh.vertices[t[0]]).cross(mesh.vertices[t[2]] - mesh.vertices[t[0]]);
      if (face.squaredNorm() > 0) face.normalize();
      for (int k = 0; k < 3; ++k) {
        const Eigen::Vector3f& p = mesh.vertices[t[k]];
        const Eigen::Vector3f normal = smooth ? mesh.normals[t[k]] : face;
        const float vertex[13] = {p.x(), p.y(), p.z(), normal.x(), normal.y(), normal.z(), color.x(), color.y(),
                                  color.z(), center.x(), center.y(), center.z(), cutaway ? 1.0f : 0.0f};
        data.insert(data.end(), vertex, vertex + 13);
      }
    }
  }
  gl.glBindBuffer(GL_ARRAY_BUFFER, solidsBuffer);
  gl.glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(data.size() * sizeof(float)), data.data(), GL_STATIC_DRAW);
  solidsVertexCount = data.size() / 13;
  solidsKey = &mesh;
  solidsKeyTriangles = mesh.triangles.size();
  solidsKeyVertices = mesh.vertices.size();
  solidsKeyHash = hash;
}

void PreviewRenderer::Impl::uploadSpheres(const ParticleSpheres& particles) {
  std::vector<float> data(particles.position.size() * 4);
  for (std::size_t i = 0; i < particles.position.size(); ++i) {
    data[4 * i + 0] = particles.position[i].x();
    data[4 * i + 1] = particles.position[i].y();
    data[4 * i + 2] = particles.position[i].z();
    data[4 * i + 3] = i < particles.speed.size() ? particles.speed[i] : 0.0f;
  }
  gl.glBindBuffer(GL_ARRAY_BUFFER, sphereBuffer);
  gl.glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(data.size() * sizeof(float)), data.data(), GL_STREAM_DRAW);
  sphereCount = particles.position.size();
}

Image PreviewRenderer::Impl::render(const FrameScene& scene) {
  makeCurrent();
  // CASCADE_RENDER_TIMING=1 prints the time of each pass (with glFinish between them).
  static const bool timing = std::getenv("CASCADE_RENDER_TIMING") != nullptr;
  auto lastMark = std::chrono::steady_clock::now();
  auto mark = [&](const char* pass) {
    if (!timing) return;
    gl.glFinish();
    const auto now = std::chrono::steady_clock::now();
    std::fprintf(stderr, "render timing: %-10s %8.1f ms\n", pass,
                 std::chrono::duration<double, std::milli>(now - lastMark).count());
    lastMark = now;
  };
  const bool hasFluid = scene.fluid && !scene.fluid->empty();
  const bool hasSolids = scene.solids && !scene.solids->empty();
  const bool hasSpheres = scene.particles && !scene.particles->position.empty();
  const bool hasWhitewater = scene.whitewater && !scene.whitewater->position.empty();

  // --- content and stage --------------------------------------------------
  float normalSign = 1.0f;
  bool clockwise = false;
  Box3f content;
  if (hasFluid) {
    uploadFluid(*scene.fluid, normalSign, clockwise);
    content.extend(meshBounds(*scene.fluid));
  } else {
    fluidIndexCount = 0;
  }
  if (hasSolids) {
    uploadSolids(*scene.solids);
    content.extend(meshBounds(*scene.solids));
  } else {
    solidsVertexCount = 0;
  }
  mark("upload");
  if (hasSpheres) {
    uploadSpheres(*scene.particles);
    for (const auto& p : scene.particles->position) content.extend(p);
    const Eigen::Vector3f pad = Eigen::Vector3f::Constant(scene.particles->radius);
    content = Box3f(content.min() - pad, content.max() + pad);
  } else {
    sphereCount = 0;
  }
  if (hasWhitewater) {  // centres only, w unused (the kinds are drawn in ranges)
    std::vector<float> data(scene.whitewater->position.size() * 4, 0.0f);
    for (std::size_t i = 0; i < scene.whitewater->position.size(); ++i)
      for (int k = 0; k < 3; ++k) data[4 * i + std::size_t(k)] = scene.whitewater->position[i][k];
    gl.glBindBuffer(GL_ARRAY_BUFFER, whitewaterBuffer);
    gl.glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(data.size() * sizeof(float)), data.data(), GL_STREAM_DRAW);
  }
  Box3f stage = scene.stage.isEmpty() ? content : scene.stage;
  if (stage.isEmpty())
    stage = Box3f(scene.camera.target - Eigen::Vector3f::Ones(), scene.camera.target + Eigen::Vector3f::Ones());
  const Eigen::Vector3f stageCenter = stage.center();
  const float stageRadius = std::max(0.5f * stage.diagonal().norm(), 1e-6f);
  Box3f all = stage;
  if (!content.isEmpty()) all.extend(content);
  const Eigen::Vector3f allCenter = all.center();
  const float allRadius = std::max(0.5f * all.diagonal().norm(), 1e-6f);
  const float groundHeight = stage.min().z() - 2e-3f * stageRadius;

  // --- camera ---------------------------------------------------------------
  const Camera& camera = scene.camera;
  const float aspect = float(width) / float(height);
  const float distance = (camera.position - allCenter).norm();
  const float farPlane = distance + 30.0f * allRadius;
  const float nearPlane = std::max(0.9f * (distance - allRadius), farPlane * 2e-5f);
  const Eigen::Matrix4f view = camera.viewMatrix();
  const Eigen::Matrix4f projection = camera.projectionMatrix(aspect, nearPlane, farPlane);
  const Eigen::Matrix4f viewProjection = projection * view;

  // --- lights: the strongest directional light (else the first) is the key --
  std::vector<Light> lights = scene.lights.empty() ? defaultLights(camera) : scene.lights;
  if (lights.size() > 1) {
    std::size_t key = 0;
    float best = -1;
    for (std::size_t i = 0; i < lights.size(); ++i)
      if (lights[i].type == Light::Type::Directional && lights[i].intensity > best) {
        best = lights[i].intensity;
        key = i;
      }
    std::swap(lights[0], lights[key]);
  }
  if (lights.size() > std::size_t(kMaxLights)) lights.resize(kMaxLights);
  const int lightCount = int(lights.size());
  float lightVectors[3 * kMaxLights] = {0}, lightRadiance[3 * kMaxLights] = {0}, lightReference[kMaxLights] = {0};
  int lightIsPoint[kMaxLights] = {0};
  for (int i = 0; i < lightCount; ++i) {
    const Light& light = lights[std::size_t(i)];
    const bool point = light.type == Light::Type::Point;
    Eigen::Vector3f vector = point ? light.position : Eigen::Vector3f(-light.direction.normalized());
    if (!point && !vector.allFinite()) vector = Eigen::Vector3f::UnitZ();
    const Eigen::Vector3f radiance = light.color * light.intensity;
    for (int k = 0; k < 3; ++k) {
      lightVectors[3 * i + k] = vector[k];
      lightRadiance[3 * i + k] = radiance[k];
    }
    lightIsPoint[i] = point ? 1 : 0;
    lightReference[i] = point ? (light.position - stageCenter).squaredNorm() : 1.0f;
  }
  Eigen::Vector3f sunDirection = Eigen::Vector3f::UnitZ(), sunColor = Eigen::Vector3f::Zero();
  Eigen::Matrix4f shadowViewProjection = Eigen::Matrix4f::Identity();
  bool shadowOrthographic = true;
  Eigen::Vector3f shadowEye = Eigen::Vector3f::Zero(), shadowAxis = Eigen::Vector3f::UnitZ();
  float shadowDepthSpan = 1.0f;
  if (lightCount > 0) {
    const Light& key = lights[0];
    if (key.type == Light::Type::Directional) {
      const Eigen::Vector3f toLight = Eigen::Vector3f(lightVectors[0], lightVectors[1], lightVectors[2]);
      sunDirection = toLight;
      sunColor = key.color * key.intensity;
      shadowEye = allCenter + toLight * (2.0f * allRadius);
      const Eigen::Vector3f up = std::abs(toLight.z()) > 0.99f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitZ();
      shadowViewProjection = orthographic(allRadius, 0.5f * allRadius, 3.5f * allRadius) *
                             lookAt(shadowEye, allCenter, up);
      shadowAxis = toLight;
      shadowDepthSpan = 3.0f * allRadius;
    } else {
      shadowOrthographic = false;
      shadowEye = key.position;
      const Eigen::Vector3f toCenter = allCenter - shadowEye;
      const float d = toCenter.norm();
      sunDirection = (shadowEye - stageCenter).normalized();
      sunColor = Eigen::Vector3f::Zero();
      const float halfAngle = d > 1.05f * allRadius ? std::asin(allRadius / d) : 1.2f;
      Camera lightCamera;
      lightCamera.position = shadowEye;
      lightCamera.target = allCenter;
      lightCamera.up = std::abs(toCenter.normalized().z()) > 0.99f ? Eigen::Vector3f::UnitX() : Eigen::Vector3f::UnitZ();
      lightCamera.fovY = 2.0f * halfAngle * 180.0f / 3.14159265f;
      const float shadowNear = std::max(d - allRadius, 0.02f * d), shadowFar = d + allRadius;
      shadowViewProjection = lightCamera.projectionMatrix(1.0f, shadowNear, shadowFar) * lightCamera.viewMatrix();
      shadowDepthSpan = shadowFar - shadowNear;
    }
    if (!sunDirection.allFinite()) sunDirection = Eigen::Vector3f::UnitZ();
  }
  Eigen::Matrix4f bias = Eigen::Matrix4f::Identity() * 0.5f;
  bias(3, 3) = 1.0f;
  bias.block<3, 1>(0, 3) = Eigen::Vector3f::Constant(0.5f);
  const Eigen::Matrix4f shadowMatrix = bias * shadowViewProjection;

  auto setCommon = [&](Program& p) {
    gl.glUseProgram(p.id);
    setVec3(p, "uCameraPosition", camera.position);
    setInt(p, "uLightCount", lightCount);
    gl.glUniform3fv(location(p, "uLightVector"), kMaxLights, lightVectors);
    gl.glUniform1iv(location(p, "uLightIsPoint"), kMaxLights, lightIsPoint);
    gl.glUniform3fv(location(p, "uLightRadiance"), kMaxLights, lightRadiance);
    gl.glUniform1fv(location(p, "uLightReference"), kMaxLights, lightReference);
    setInt(p, "uShadowMap", 0);
    setInt(p, "uWaterShadowMap", 6);
    setInt(p, "uWaterShadows", lightCount > 0 && fluidIndexCount > 0 ? 1 : 0);
    setMatrix(p, "uShadowMatrix", shadowMatrix);
    setFloat(p, "uShadowTexel", 1.0f / kShadowMapSize);
    setFloat(p, "uShadowBias", std::min(0.02f, 0.004f * allRadius / shadowDepthSpan + 1e-4f));
    setVec3(p, "uSunDirection", sunDirection);
    setVec3(p, "uSunColor", sunColor);
    setInt(p, "uDrawSky", look.drawSky ? 1 : 0);
    setVec3(p, "uBackground", look.background);
    setVec3(p, "uStageCenter", stageCenter);
    setFloat(p, "uStageRadius", stageRadius);
    setFloat(p, "uGroundHeight", groundHeight);
    setMatrix(p, "uViewProjection", viewProjection);
  };
  auto drawFluid = [&] {
    gl.glBindVertexArray(fluidVao);
    gl.glVertexAttrib3f(2, 0, 0, 0);
    gl.glVertexAttrib4f(3, 0, 0, 0, 0);
    gl.glDrawElements(GL_TRIANGLES, GLsizei(fluidIndexCount), GL_UNSIGNED_INT, nullptr);
  };
  auto drawSolids = [&] {
    gl.glBindVertexArray(solidsVao);
    gl.glDrawArrays(GL_TRIANGLES, 0, GLsizei(solidsVertexCount));
  };
  auto drawSpheres = [&] {
    gl.glBindVertexArray(sphereVao);
    gl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(sphereCount));
  };
  const float sphereRadius = hasSpheres ? scene.particles->radius : 0.0f;

  gl.glActiveTexture(GL_TEXTURE0);
  gl.glBindTexture(GL_TEXTURE_2D, shadowTexture);
  gl.glEnable(GL_DEPTH_TEST);
  gl.glDepthFunc(GL_LESS);
  gl.glDisable(GL_BLEND);
  gl.glDisable(GL_CULL_FACE);

  // --- 1. shadow map --------------------------------------------------------
  gl.glBindFramebuffer(GL_FRAMEBUFFER, shadowFbo);
  gl.glViewport(0, 0, kShadowMapSize, kShadowMapSize);
  gl.glDepthMask(GL_TRUE);
  gl.glClearDepth(1.0);
  gl.glClear(GL_DEPTH_BUFFER_BIT);
  if (lightCount > 0) {
    gl.glBindTexture(GL_TEXTURE_2D, 0);  // the shadow map is the target now
    gl.glEnable(GL_POLYGON_OFFSET_FILL);
    gl.glPolygonOffset(1.5f, 2.0f);
    if (solidsVertexCount) {
      gl.glUseProgram(solidShadowProgram.id);
      setMatrix(solidShadowProgram, "uViewProjection", shadowViewProjection);
      setFloat(solidShadowProgram, "uNormalSign", 1.0f);
      setVec3(solidShadowProgram, "uCameraPosition", camera.position);
      drawSolids();
    }
    if (sphereCount) {
      gl.glUseProgram(sphereShadowProgram.id);
      setMatrix(sphereShadowProgram, "uViewProjection", shadowViewProjection);
      setVec3(sphereShadowProgram, "uEye", shadowEye);
      setVec3(sphereShadowProgram, "uAxis", shadowAxis);
      setInt(sphereShadowProgram, "uOrthographic", shadowOrthographic ? 1 : 0);
      setFloat(sphereShadowProgram, "uRadius", sphereRadius);
      drawSpheres();
    }
    if (fluidIndexCount) {  // water's own map: it shadows only in part
      gl.glBindFramebuffer(GL_FRAMEBUFFER, waterShadowFbo);
      gl.glClear(GL_DEPTH_BUFFER_BIT);
      gl.glUseProgram(depthProgram.id);
      setMatrix(depthProgram, "uViewProjection", shadowViewProjection);
      gl.glEnable(GL_CULL_FACE);  // a closed surface casts the same shadow from its back faces alone
      gl.glFrontFace(clockwise ? GL_CW : GL_CCW);
      gl.glCullFace(GL_FRONT);
      drawFluid();
      gl.glDisable(GL_CULL_FACE);
      gl.glFrontFace(GL_CCW);
    }
    gl.glDisable(GL_POLYGON_OFFSET_FILL);
    gl.glBindTexture(GL_TEXTURE_2D, shadowTexture);
  }
  gl.glActiveTexture(GL_TEXTURE6);
  gl.glBindTexture(GL_TEXTURE_2D, waterShadowTexture);
  gl.glActiveTexture(GL_TEXTURE0);
  mark("shadow");

  // --- 2. opaque pass ------------------------------------------------------
  gl.glBindFramebuffer(GL_FRAMEBUFFER, msFbo);
  gl.glViewport(0, 0, internalWidth, internalHeight);
  if (multisamples > 1) gl.glEnable(GL_MULTISAMPLE);
  gl.glClearColor(look.background.x(), look.background.y(), look.background.z(), 0.0f);
  gl.glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  if (solidsVertexCount) {
    setCommon(solidProgram);
    setFloat(solidProgram, "uNormalSign", 1.0f);
    drawSolids();
  }
  mark("solids");
  if (sphereCount) {
    setCommon(sphereProgram);
    setVec3(sphereProgram, "uEye", camera.position);
    setInt(sphereProgram, "uOrthographic", 0);
    setFloat(sphereProgram, "uRadius", sphereRadius);
    setFloat(sphereProgram, "uSpeedScale", std::max(scene.particles->speedScale, 1e-6f));
    setFloat(sphereProgram, "uWhite", 0.0f);
    if (multisamples > 1) {  // shade per sample: the impostors' edges come from discard
      gl.glEnable(GL_SAMPLE_SHADING);
      gl.glMinSampleShading(1.0f);
    }
    drawSpheres();
    if (multisamples > 1) gl.glDisable(GL_SAMPLE_SHADING);
  }
  if (hasWhitewater) {  // each kind its own radius: a range of the buffer per draw
    const WhitewaterSprites& sprites = *scene.whitewater;
    setCommon(sphereProgram);
    setVec3(sphereProgram, "uEye", camera.position);
    setInt(sphereProgram, "uOrthographic", 0);
    setFloat(sphereProgram, "uSpeedScale", 1.0f);
    setFloat(sphereProgram, "uWhite", 1.0f);
    gl.glBindVertexArray(whitewaterVao);
    gl.glBindBuffer(GL_ARRAY_BUFFER, whitewaterBuffer);
    std::size_t first = 0;
    for (std::size_t kind = 0; kind < 3; ++kind) {
      if (sprites.count[kind] > 0) {
        setFloat(sphereProgram, "uRadius", sprites.radius[kind]);
        gl.glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, reinterpret_cast<void*>(first * 4 * sizeof(float)));
        gl.glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, GLsizei(sprites.count[kind]));
      }
      first += sprites.count[kind];
    }
    gl.glVertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 0, nullptr);
  }
  mark("spheres");
  if (look.drawGround) {
    const float extent = 25.0f * allRadius;
    const float ground[12] = {stageCenter.x() - extent, stageCenter.y() - extent, groundHeight,
                              stageCenter.x() + extent, stageCenter.y() - extent, groundHeight,
                              stageCenter.x() - extent, stageCenter.y() + extent, groundHeight,
                              stageCenter.x() + extent, stageCenter.y() + extent, groundHeight};
    gl.glBindBuffer(GL_ARRAY_BUFFER, groundBuffer);
    gl.glBufferData(GL_ARRAY_BUFFER, sizeof ground, ground, GL_STREAM_DRAW);
    setCommon(groundProgram);
    setFloat(groundProgram, "uNormalSign", 1.0f);
    setFloat(groundProgram, "uTileSize", niceTile(stageRadius / 3.0f));
    gl.glBindVertexArray(groundVao);
    gl.glVertexAttrib3f(1, 0, 0, 1);
    gl.glVertexAttrib3f(2, 0, 0, 0);
    gl.glVertexAttrib4f(3, 0, 0, 0, 0);
    gl.glDrawArrays(GL_TRIANGLE_STRIP, 0, 4);
  }
  mark("ground");
  {  // the sky last, on the far plane, where depth is still clear
    gl.glDepthFunc(GL_LEQUAL);
    gl.glDepthMask(GL_FALSE);
    setCommon(skyProgram);
    const Eigen::Matrix4f inverse = viewProjection.inverse();
    setMatrix(skyProgram, "uInverseViewProjection", inverse);
    setFloat(skyProgram, "uFullscreenDepth", 1.0f);
    gl.glBindVertexArray(emptyVao);
    gl.glDrawArrays(GL_TRIANGLES, 0, 3);
    gl.glDepthFunc(GL_LESS);
    gl.glDepthMask(GL_TRUE);
  }
  mark("sky");

  // --- 3. resolve the opaque image; the water's back faces and buffers --------
  gl.glBindFramebuffer(GL_READ_FRAMEBUFFER, msFbo);
  gl.glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolveFbo);
  gl.glBlitFramebuffer(0, 0, internalWidth, internalHeight, 0, 0, internalWidth, internalHeight,
                       GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT, GL_NEAREST);
  mark("resolve");
  if (fluidIndexCount) {
    gl.glBindFramebuffer(GL_FRAMEBUFFER, backFbo);
    gl.glClear(GL_DEPTH_BUFFER_BIT);
    gl.glEnable(GL_CULL_FACE);
    gl.glFrontFace(clockwise ? GL_CW : GL_CCW);
    gl.glCullFace(GL_FRONT);
    gl.glUseProgram(depthProgram.id);
    setMatrix(depthProgram, "uViewProjection", viewProjection);
    drawFluid();
    mark("back");

    gl.glBindFramebuffer(GL_FRAMEBUFFER, waterFbo);
    gl.glViewport(0, 0, internalWidth * waterScale, internalHeight * waterScale);
    const float zero[4] = {0, 0, 0, 0};
    gl.glClearBufferfv(GL_COLOR, 0, zero);
    gl.glClearBufferfv(GL_COLOR, 1, zero);
    gl.glClear(GL_DEPTH_BUFFER_BIT);
    gl.glCullFace(GL_BACK);
    gl.glUseProgram(waterBufferProgram.id);
    setMatrix(waterBufferProgram, "uViewProjection", viewProjection);
    setFloat(waterBufferProgram, "uNormalSign", normalSign);
    setVec3(waterBufferProgram, "uCameraPosition", camera.position);
    setVec3(waterBufferProgram, "uCameraForward", camera.forward());
    gl.glActiveTexture(GL_TEXTURE1);
    gl.glBindTexture(GL_TEXTURE_2D, resolveDepth);
    gl.glActiveTexture(GL_TEXTURE0);
    setInt(waterBufferProgram, "uOpaqueDepth", 1);
    setVec2(waterBufferProgram, "uWaterSize", float(internalWidth * waterScale), float(internalHeight * waterScale));
    drawFluid();
    gl.glDisable(GL_CULL_FACE);
    gl.glFrontFace(GL_CCW);
    mark("water");
  }

  // --- 4. shade the water texels over the opaque image ----------------------
  GLuint hdr = resolveColor;
  if (fluidIndexCount) {
    gl.glBindFramebuffer(GL_FRAMEBUFFER, compositeFbo);
    gl.glViewport(0, 0, internalWidth, internalHeight);
    gl.glBindVertexArray(emptyVao);
    gl.glEnable(GL_DEPTH_TEST);
    gl.glDepthFunc(GL_ALWAYS);
    gl.glDepthMask(GL_TRUE);
    gl.glUseProgram(waterMaskProgram.id);
    gl.glActiveTexture(GL_TEXTURE1);
    gl.glBindTexture(GL_TEXTURE_2D, resolveColor);
    gl.glActiveTexture(GL_TEXTURE2);
    gl.glBindTexture(GL_TEXTURE_2D, waterNormal);
    gl.glActiveTexture(GL_TEXTURE0);
    setInt(waterMaskProgram, "uOpaqueColor", 1);
    setInt(waterMaskProgram, "uWaterNormal", 2);
    setFloat(waterMaskProgram, "uFullscreenDepth", 0.0f);
    gl.glDrawArrays(GL_TRIANGLES, 0, 3);
    mark("mask");

    gl.glDepthFunc(GL_GREATER);  // NDC 0 -> depth 0.5 > 0 where water
    gl.glDepthMask(GL_FALSE);
    setCommon(waterShadeProgram);
    const GLuint inputs[5] = {resolveColor, resolveDepth, backDepth, waterNormal, waterDepth};
    const char* names[5] = {"uOpaqueColor", "uOpaqueDepth", "uBackDepth", "uWaterNormal", "uWaterDepth"};
    for (int k = 0; k < 5; ++k) {
      gl.glActiveTexture(GLenum(GL_TEXTURE1 + k));
      gl.glBindTexture(GL_TEXTURE_2D, inputs[k]);
      setInt(waterShadeProgram, names[k], 1 + k);
    }
    gl.glActiveTexture(GL_TEXTURE0);
    setFloat(waterShadeProgram, "uFullscreenDepth", 0.0f);
    setVec2(waterShadeProgram, "uInternalSize", float(internalWidth), float(internalHeight));
    setVec2(waterShadeProgram, "uDepthRange", nearPlane, farPlane);
    setMatrix(waterShadeProgram, "uView", view);
    setMatrix(waterShadeProgram, "uInverseViewProjection", Eigen::Matrix4f(viewProjection.inverse()));
    setVec3(waterShadeProgram, "uCameraForward", camera.forward());
    setVec3(waterShadeProgram, "uDeepWaterColor", look.deepWaterColor);
    setVec3(waterShadeProgram, "uAbsorption", look.absorption);
    const float stageHeight = stage.sizes().z();
    setFloat(waterShadeProgram, "uAbsorptionLength",
             0.1f * (stageHeight > 0.05f * stageRadius ? stageHeight : stageRadius));
    setFloat(waterShadeProgram, "uRefraction", 0.035f);
    gl.glDrawArrays(GL_TRIANGLES, 0, 3);
    gl.glDepthFunc(GL_LESS);
    gl.glDepthMask(GL_TRUE);
    for (int k = 5; k >= 1; --k) {
      gl.glActiveTexture(GLenum(GL_TEXTURE0 + k));
      gl.glBindTexture(GL_TEXTURE_2D, 0);
    }
    gl.glActiveTexture(GL_TEXTURE0);
    hdr = compositeColor;
    mark("shade");
  }

  // --- 5. tone map, read back ---------------------------------------------------
  gl.glBindFramebuffer(GL_FRAMEBUFFER, outFbo);
  gl.glViewport(0, 0, width, height);
  gl.glDisable(GL_DEPTH_TEST);
  gl.glUseProgram(toneMapProgram.id);
  gl.glBindTexture(GL_TEXTURE_2D, hdr);
  setInt(toneMapProgram, "uHdr", 0);
  setFloat(toneMapProgram, "uExposure", look.exposure);
  setFloat(toneMapProgram, "uFullscreenDepth", 0.0f);
  gl.glBindVertexArray(emptyVao);
  gl.glDrawArrays(GL_TRIANGLES, 0, 3);

  Image image(width, height);
  gl.glPixelStorei(GL_PACK_ALIGNMENT, 1);
  gl.glBindFramebuffer(GL_READ_FRAMEBUFFER, outFbo);
  gl.glReadBuffer(GL_COLOR_ATTACHMENT0);
  std::vector<std::uint8_t> bottomUp(image.rgba.size());
  gl.glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, bottomUp.data());
  mark("tonemap");
  const GLenum error = gl.glGetError();
  gl.glBindFramebuffer(GL_FRAMEBUFFER, 0);
  gl.glBindVertexArray(0);
  if (error != GL_NO_ERROR) {
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", error);
    throw std::runtime_error(std::string("render: OpenGL error ") + code);
  }
  const std::size_t rowBytes = std::size_t(width) * 4;
  for (int y = 0; y < height; ++y)
    std::memcpy(image.pixel(0, y), bottomUp.data() + std::size_t(height - 1 - y) * rowBytes, rowBytes);
  return image;
}

PreviewRenderer::PreviewRenderer(int width, int height, int samples, RenderLook look)
    : mImpl(std::make_unique<Impl>(width, height, samples, std::move(look))) {}

PreviewRenderer::~PreviewRenderer() = default;

Image PreviewRenderer::render(const FrameScene& scene) { return mImpl->render(scene); }
int PreviewRenderer::width() const { return mImpl->width; }
int PreviewRenderer::height() const { return mImpl->height; }
int PreviewRenderer::effectiveSamples() const {
  return mImpl->multisamples * mImpl->supersample * mImpl->supersample;
}
std::string PreviewRenderer::glDescription() const { return mImpl->description; }

} // namespace cascade::render
