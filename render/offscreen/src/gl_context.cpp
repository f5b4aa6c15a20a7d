// One GL context's objects (gl_context.h) and the shaders every context compiles.
#include "gl_context.h"

#include <dirent.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "facespace/engine/cpu.h"

namespace facespace::offscreen {

namespace {

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_color;
layout(location = 4) in float a_scalar;
layout(location = 5) in vec4 a_occlusion;  // Baked (core/occlusion.h): ao, then b in the normal's frame.
uniform mat4 u_view;
uniform mat4 u_proj;
out float v_ao;
out vec3 v_seen;     // View space: b, 4 x the mean visible direction.
out vec3 v_pos;      // View space.
out vec3 v_normal;   // View space.
out vec3 v_world_normal;
out vec2 v_uv;
out vec4 v_color;
out float v_scalar;
void main() {
  vec4 p = u_view * vec4(a_pos, 1.0);
  v_pos = p.xyz;
  v_normal = mat3(u_view) * a_normal;
  v_world_normal = a_normal;
  v_uv = a_uv;
  v_color = a_color;
  v_scalar = a_scalar;
  // b out of the frame the bake stored it in (OcclusionFrame: Duff et al.), built on the drawn normal.
  vec3 n = normalize(a_normal);
  float sgn = n.z >= 0.0 ? 1.0 : -1.0;
  float a = -1.0 / (sgn + n.z), b = n.x * n.y * a;
  vec3 t = vec3(1.0 + sgn * n.x * n.x * a, sgn * b, -sgn * n.x), s = vec3(b, sgn + n.y * n.y * a, -n.y);
  v_seen = mat3(u_view) * (a_occlusion.y * t + a_occlusion.z * s + a_occlusion.w * n);
  v_ao = a_occlusion.x;
  gl_Position = u_proj * p;
}
)";

// One program per variant (GlContext::Program): MODE (0 shaded with the material, 1 flat colour,
// 2 heatmap, 3 normals, 4 clay), ALPHA_MODE (0 opaque, 1 mask, 2 blend), HAS_* (the material's
// textures) and LABELS (the label planes written too) are defined before this text. llvmpipe runs
// both sides of every branch with masks, so one program branching on uniforms paid for every mode
// and every texture on each fragment.
const char* kFragmentShader = R"(
in vec3 v_pos;
in vec3 v_normal;
in vec3 v_world_normal;
in vec2 v_uv;
in vec4 v_color;
in float v_scalar;
in float v_ao;
in vec3 v_seen;
uniform float u_baked;       // 1: the baked occlusion shades; 0: every point is open.
uniform vec4 u_base_color;   // Linear.
uniform sampler2D u_texture; // sRGB texture: sampled as linear.
uniform vec2 u_metal_rough;
uniform sampler2D u_metal_rough_texture;  // Linear: roughness in G, metallic in B.
uniform float u_normal_scale;
uniform sampler2D u_normal_texture;       // Linear, tangent space.
uniform float u_occlusion_strength;
uniform sampler2D u_occlusion_texture;    // Linear, R.
uniform vec3 u_emissive;
uniform sampler2D u_emissive_texture;     // sRGB.
uniform float u_alpha_cutoff;
uniform float u_exposure;    // Multiplies the light before tone mapping.
uniform float u_heat_max;
uniform mat3 u_light;        // Turns the studio's lights (RenderOptions::light_yaw, light_pitch).
uniform float u_segment;     // LABELS: the draw's segment id.
layout(location = 0) out vec4 frag;
#if LABELS  // The label planes (RenderOptions::labels): distance along the ray and camera-space normal; segment.
layout(location = 1) out vec4 frag_label;
layout(location = 2) out vec4 frag_segment;
#endif
const float PI = 3.14159265;
vec3 viridis(float t) {
  // Polynomial fit of matplotlib's viridis (perceptually uniform), sRGB output.
  const vec3 c0 = vec3(0.2777273272234177, 0.005407344544966578, 0.3340998053353061);
  const vec3 c1 = vec3(0.1050930431085774, 1.404613529898575, 1.384590162594685);
  const vec3 c2 = vec3(-0.3308618287255563, 0.214847559468213, 0.09509516302823659);
  const vec3 c3 = vec3(-4.634230498983486, -5.799100973351585, -19.33244095627987);
  const vec3 c4 = vec3(6.228269936347081, 14.17993336680509, 56.69055260068105);
  const vec3 c5 = vec3(4.776384997670288, -13.74514537774601, -65.35303263337234);
  const vec3 c6 = vec3(-5.435455855934631, 4.645852612178535, 26.3124352495832);
  t = clamp(t, 0.0, 1.0);
  return c0 + t * (c1 + t * (c2 + t * (c3 + t * (c4 + t * (c5 + t * c6)))));
}
vec3 srgb_to_linear(vec3 c) { return pow(max(c, vec3(0.0)), vec3(2.2)); }
// Khronos PBR Neutral tone mapping: base colours come out as authored up to 0.8, highlights roll off.
vec3 pbr_neutral(vec3 color) {
  const float start = 0.8 - 0.04, desaturation = 0.15;
  float x = min(color.r, min(color.g, color.b));
  color -= x < 0.08 ? x - 6.25 * x * x : 0.04;
  float peak = max(color.r, max(color.g, color.b));
  if (peak < start) return color;
  const float d = 1.0 - start;
  float new_peak = 1.0 - d * d / (peak + d - start);
  color *= new_peak / peak;
  float g = 1.0 - 1.0 / (desaturation * (peak - new_peak) + 1.0);
  return mix(color, vec3(new_peak), g);
}
// The normal map's normal in a frame built from screen-space derivatives of position and UV
// (no tangents needed); glTF's green points up the image, toward smaller v.
vec3 mapped_normal(vec3 n) {
  vec3 dp1 = dFdx(v_pos), dp2 = dFdy(v_pos);
  vec2 duv1 = dFdx(v_uv), duv2 = dFdy(v_uv);
  vec3 dp2perp = cross(dp2, n), dp1perp = cross(n, dp1);
  vec3 t = dp2perp * duv1.x + dp1perp * duv2.x;
  vec3 b = dp2perp * duv1.y + dp1perp * duv2.y;
  float len2 = max(dot(t, t), dot(b, b));
  if (!(len2 > 1e-30)) return n;
  float inv = inversesqrt(len2);
  vec3 m = texture(u_normal_texture, v_uv).xyz * 2.0 - 1.0;
  m.xy *= u_normal_scale;
  vec3 r = mat3(t * inv, -b * inv, n) * m;
  return dot(r, r) > 0.0 ? normalize(r) : n;
}
// Split-sum environment BRDF, analytic fit (Karis, "Physically Based Shading on Mobile").
vec3 env_brdf(vec3 f0, float rough, float nv) {
  const vec4 c0 = vec4(-1.0, -0.0275, -0.572, 0.022);
  const vec4 c1 = vec4(1.0, 0.0425, 1.04, -0.04);
  vec4 r = rough * c0 + c1;
  float a004 = min(r.x * r.x, exp2(-9.28 * nv)) * r.x + r.y;
  vec2 ab = vec2(-1.04, 1.04) * a004 + r.zw;
  return f0 * ab.x + ab.y;
}
// How much of a light from l reaches this point (core/occlusion.h's LightVisibility), and of the sky
// (ambient occlusion); a back face, whose bake was the front's, is open. At least OCCLUSION_FLOOR: the
// bake is of the closed neutral face, and what an open mouth shows (teeth, tongue) still gets some light
// bounced in, rather than none.
const float OCCLUSION_FLOOR = 0.06;
float light_seen(vec3 n, vec3 l) {
  float open = 0.5 + 0.75 * max(dot(n, l), 0.0);
  float seen = clamp((0.5 * v_ao + 0.75 * dot(v_seen, l)) / open, OCCLUSION_FLOOR, 1.0);
  return gl_FrontFacing ? mix(1.0, seen, u_baked) : 1.0;
}
float sky_seen() { return gl_FrontFacing ? mix(1.0, max(v_ao, OCCLUSION_FLOOR), u_baked) : 1.0; }
// A studio in view space (camera looks down -z): key light high on the left, fill low on the
// right, rim behind; a sky-to-floor gradient for the ambient and reflections. Its level is set
// against three.js's RoomEnvironment under the same tone mapping (tests/render/reference): the
// models' mean colours agree within a few hundredths there (three.js 0.170.0).
const float STUDIO_LEVEL = 1.6;  // +0.7 stops over the light below.
vec3 studio(vec3 n, vec3 v, vec3 albedo, float metallic, float rough, float occlusion) {
  const vec3 dirs[3] = vec3[3](vec3(-0.52, 0.58, 0.63), vec3(0.80, 0.05, 0.60), vec3(0.40, 0.55, -0.73));
  const vec3 radiance[3] = vec3[3](vec3(2.2, 2.1, 2.0), vec3(0.55, 0.6, 0.68), vec3(1.4));
  const vec3 sky = vec3(0.24, 0.25, 0.28), floor_ = vec3(0.07, 0.065, 0.06);
  rough = clamp(rough, 0.045, 1.0);
  float a2 = rough * rough * rough * rough;
  vec3 f0 = mix(vec3(0.04), albedo, metallic);
  vec3 diffuse = (1.0 - metallic) * albedo;
  float nv = max(dot(n, v), 1e-4);
  vec3 color = vec3(0.0);
  for (int i = 0; i < 3; ++i) {
    vec3 l = normalize(u_light * dirs[i]);
    float nl = dot(n, l);
    if (nl <= 0.0) continue;
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0), vh = max(dot(v, h), 0.0);
    float q = nh * nh * (a2 - 1.0) + 1.0;
    float D = a2 / (PI * q * q);
    float V = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    vec3 F = f0 + (1.0 - f0) * pow(1.0 - vh, 5.0);
    color += ((1.0 - F) * diffuse / PI + D * V * F) * radiance[i] * nl * light_seen(n, l);
  }
  occlusion *= sky_seen();
  vec3 ambient = mix(floor_, sky, n.y * 0.5 + 0.5);
  vec3 r = reflect(-v, n);
  vec3 reflected = mix(floor_, sky, clamp(r.y * 0.5 + 0.5, 0.0, 1.0));
  color += occlusion * (ambient * diffuse + reflected * env_brdf(f0, rough, nv));
  return STUDIO_LEVEL * color;
}
void main() {
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
  vec3 label_n = n;
#if MODE == 1
  frag = vec4(0.02, 0.02, 0.03, 1.0);
#elif MODE == 3
  frag = vec4(srgb_to_linear(normalize(v_world_normal) * 0.5 + 0.5), 1.0);
#elif MODE == 2  // Heatmap: the colour map under a plain light, so colours read against the legend.
  vec3 view_dir = normalize(-v_pos);
  vec3 base = srgb_to_linear(viridis(u_heat_max > 0.0 ? v_scalar / u_heat_max : 0.0));
  vec3 lights[2] = vec3[2](normalize(vec3(-0.45, 0.6, 0.9)), normalize(vec3(0.7, 0.15, 0.6)));
  float power[2] = float[2](0.85, 0.35);
  vec3 color = 0.18 * base;
  for (int i = 0; i < 2; ++i) {
    float diff = max(dot(n, lights[i]), 0.0);
    vec3 h = normalize(lights[i] + view_dir);
    float spec = diff > 0.0 ? pow(max(dot(n, h), 0.0), 48.0) : 0.0;
    color += power[i] * (diff * base + 0.05 * spec);
  }
  frag = vec4(color, 1.0);
#elif MODE == 4  // Clay: one neutral material for shape-only work.
  frag = vec4(pbr_neutral(u_exposure * studio(n, normalize(-v_pos), vec3(0.42), 0.0, 0.55, 1.0)), 1.0);
#else
  vec3 view_dir = normalize(-v_pos);
  vec4 base = u_base_color * v_color;
#if HAS_TEXTURE
  base *= texture(u_texture, v_uv);
#endif
#if ALPHA_MODE == 1
  if (base.a < u_alpha_cutoff) discard;
#endif
  float metallic = u_metal_rough.x, rough = u_metal_rough.y;
#if HAS_METAL_ROUGH
  vec4 mr = texture(u_metal_rough_texture, v_uv);
  rough *= mr.g;
  metallic *= mr.b;
#endif
#if HAS_NORMAL_MAP
  n = mapped_normal(n);
#endif
  float occlusion = 1.0;
#if HAS_OCCLUSION
  occlusion = 1.0 + u_occlusion_strength * (texture(u_occlusion_texture, v_uv).r - 1.0);
#endif
  vec3 emissive = u_emissive;
#if HAS_EMISSIVE
  emissive *= texture(u_emissive_texture, v_uv).rgb;
#endif
  vec3 color = studio(n, view_dir, base.rgb, clamp(metallic, 0.0, 1.0), rough, occlusion) + emissive;
  frag = vec4(pbr_neutral(u_exposure * color), ALPHA_MODE == 2 ? base.a : 1.0);
#endif
#if LABELS  // The interpolated vertex normal facing the eye (no normal map): the surface's, not its shading's.
  frag_label = vec4(length(v_pos), label_n);
  frag_segment = vec4(u_segment, 0.0, 0.0, 1.0);
#endif
}
)";

}  // namespace

uint64_t TextureKey(std::span<const unsigned char> bytes, bool srgb_data) {
  const size_t size = bytes.size(), edge = size <= 65536 ? size : 32768;
  uint64_t key = (1469598103934665603ull ^ size) + (srgb_data ? 0 : 0x9e3779b97f4a7c15ull);
  auto mix = [&key](uint64_t word) {
    key = (key ^ word) * 0x9fb21c651e98df25ull;
    key ^= key >> 29;
  };
  auto word_at = [&bytes](size_t i) {  // Eight bytes from i, fewer at the end (zero-padded).
    uint64_t word = 0;
    std::memcpy(&word, bytes.data() + i, std::min<size_t>(8, bytes.size() - i));
    return word;
  };
  for (size_t i = 0; i < edge; i += 8) mix(word_at(i));
  for (size_t i = edge; i + edge < size; i += 61 * 8) mix(word_at(i));
  for (size_t i = std::max(edge, size - edge); i < size; i += 8) mix(word_at(i));
  return key;
}

GlContext::~GlContext() {
  if (ctx) OSMesaDestroyContext(ctx);
}

// Creates the context and makes it current on the calling thread.
bool GlContext::Init() {
  const int attribs[] = {OSMESA_FORMAT,
                         OSMESA_RGBA,
                         OSMESA_DEPTH_BITS,
                         24,
                         OSMESA_PROFILE,
                         OSMESA_CORE_PROFILE,
                         OSMESA_CONTEXT_MAJOR_VERSION,
                         3,
                         OSMESA_CONTEXT_MINOR_VERSION,
                         3,
                         0};
  ctx = OSMesaCreateContextAttribs(attribs, nullptr);
  if (!ctx) {
    error = "OSMesa could not create a GL 3.3 core context";
    return false;
  }
  if (!MakeCurrent()) return false;
  info = std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + ", OpenGL " +
         reinterpret_cast<const char*>(glGetString(GL_VERSION));
  GLint extensions = 0;
  glGetIntegerv(GL_NUM_EXTENSIONS, &extensions);
  for (GLint i = 0; i < extensions; ++i) {
    if (std::strcmp(
            reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i))),
            "GL_MESA_pack_invert") == 0)
      pack_invert = true;
  }
  vertex_shader = Compile(GL_VERTEX_SHADER, kVertexShader);
  if (!vertex_shader || !Program(0))
    return false;  // The shaded, untextured variant: every render's first.
  glGenVertexArrays(1, &vao);
  glGenBuffers(1, &vbo);
  glGenBuffers(1, &ibo);
  return true;
}

bool GlContext::MakeCurrent() {
  if (OSMesaMakeCurrent(ctx, dummy.data(), GL_UNSIGNED_BYTE, 16, 16)) return true;
  error = "OSMesaMakeCurrent failed";
  return false;
}

GLuint GlContext::Compile(GLenum type, const char* src) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &src, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    error = std::string("shader: ") + log;
    return 0;
  }
  return s;
}

// The fragment program of one variant (ShaderKey), compiled and linked on first use; 0 and
// `error` when it fails.
GLuint GlContext::Program(int key) {
  for (const auto& [k, p] : programs) {
    if (k == key) return p;
  }
  const std::string defines =
      "#version 330 core\n#define MODE " + std::to_string(key & 7) + "\n#define ALPHA_MODE " +
      std::to_string((key >> 3) & 3) + "\n#define HAS_TEXTURE " + std::to_string((key >> 5) & 1) +
      "\n#define HAS_METAL_ROUGH " + std::to_string((key >> 6) & 1) + "\n#define HAS_NORMAL_MAP " +
      std::to_string((key >> 7) & 1) + "\n#define HAS_OCCLUSION " + std::to_string((key >> 8) & 1) +
      "\n#define HAS_EMISSIVE " + std::to_string((key >> 9) & 1) + "\n#define LABELS " +
      std::to_string((key >> 10) & 1) + "\n";
  const GLuint fs = Compile(GL_FRAGMENT_SHADER, (defines + kFragmentShader).c_str());
  if (!fs) return 0;
  const GLuint p = glCreateProgram();
  glAttachShader(p, vertex_shader);
  glAttachShader(p, fs);
  glLinkProgram(p);
  glDeleteShader(fs);  // Freed with the program.
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    glDeleteProgram(p);
    error = "shader program failed to link";
    return 0;
  }
  programs.emplace_back(key, p);
  return p;
}

// After a large render (over 1024 x 1024 samples: 20 bytes a sample in the targets, 16 in the
// read-back) its targets and read-back are let go, so a context does not keep hundreds of
// megabytes, or gigabytes, for the next, likely smaller, render.
void GlContext::TrimLarge() {
  constexpr long long kKept = 1024LL * 1024;
  for (Target& t : targets) {
    if (t.fbo && static_cast<long long>(t.w) * t.h > kKept) FreeTarget(t);
  }
  if (pixels.capacity() > static_cast<size_t>(kKept) * 4) std::vector<float>().swap(pixels);
}

void GlContext::FreeTarget(Target& t) {
  glDeleteFramebuffers(1, &t.fbo);
  glDeleteRenderbuffers(1, &t.color);
  glDeleteRenderbuffers(1, &t.depth);
  for (GLuint& rb : t.labels) {
    if (rb) glDeleteRenderbuffers(1, &rb);
  }
  t = Target{};
}

// A renderbuffer of `format`, w x h, attached to the bound framebuffer at `attachment`.
static GLuint Attach(GLenum format, GLenum attachment, int w, int h) {
  GLuint rb = 0;
  glGenRenderbuffers(1, &rb);
  glBindRenderbuffer(GL_RENDERBUFFER, rb);
  glRenderbufferStorage(GL_RENDERBUFFER, format, w, h);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, attachment, GL_RENDERBUFFER, rb);
  return rb;
}

// Binds the target of that kind (srgb8: 8-bit sRGB, else float), made or resized to w x h.
void GlContext::BindTarget(int w, int h, bool srgb8, bool labels) {
  Target& t = targets[srgb8 ? 1 : 0];
  if (w != t.w || h != t.h || !t.fbo) {
    if (t.fbo) FreeTarget(t);
    glGenFramebuffers(1, &t.fbo);
    glBindFramebuffer(GL_FRAMEBUFFER, t.fbo);
    t.color = Attach(srgb8 ? GL_SRGB8_ALPHA8 : GL_RGBA32F, GL_COLOR_ATTACHMENT0, w, h);
    t.depth = Attach(GL_DEPTH_COMPONENT24, GL_DEPTH_ATTACHMENT, w, h);
    t.w = w;
    t.h = h;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, t.fbo);
  if (labels && !t.labels[0]) {
    t.labels[0] = Attach(GL_RGBA32F, GL_COLOR_ATTACHMENT1, w, h);
    t.labels[1] = Attach(GL_R32F, GL_COLOR_ATTACHMENT2, w, h);
  }
  const GLenum buffers[3] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1, GL_COLOR_ATTACHMENT2};
  glDrawBuffers(labels ? 3 : 1, buffers);
  // Shader outputs are linear: GL converts them (and the clear colour, and blends) to sRGB at the
  // store.
  if (srgb8)
    glEnable(GL_FRAMEBUFFER_SRGB);
  else
    glDisable(GL_FRAMEBUFFER_SRGB);
}

// The GL texture of an encoded image, decoded once per thread (a few kept).
// Colour maps are sRGB (sampled as linear), data maps (normals, roughness, occlusion) linear.
GLuint GlContext::TextureFor(const facespace::Image& image, bool srgb_data) {
  const uint64_t key = TextureKey(image.bytes, srgb_data);
  for (auto it = textures.begin(); it != textures.end(); ++it) {
    if (it->key == key) {
      textures.splice(textures.begin(), textures, it);
      return it->id;
    }
  }
  if (image.bytes.empty()) return 0;
  auto decoded = Decode(image.bytes, image.mime_type);
  if (!decoded.ok()) return 0;
  const picture::Image& im = decoded.value();
  std::vector<unsigned char> srgb(
      im.rgba.size());  // The file's own 8-bit values (Decode made them linear).
  for (size_t i = 0; i < im.rgba.size(); ++i) {
    const float c = im.rgba[i];
    const float e =
        (i % 4 == 3) ? c : (c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1 / 2.4f) - 0.055f);
    srgb[i] = static_cast<unsigned char>(std::lround(std::clamp(e, 0.0f, 1.0f) * 255.0f));
  }
  GLuint id = 0;
  glGenTextures(1, &id);
  glBindTexture(GL_TEXTURE_2D, id);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, srgb_data ? GL_SRGB8_ALPHA8 : GL_RGBA8, im.width, im.height, 0,
               GL_RGBA, GL_UNSIGNED_BYTE, srgb.data());
  glGenerateMipmap(GL_TEXTURE_2D);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_REPEAT);
  textures.push_front({key, id});
  if (textures.size() > 16) {
    glDeleteTextures(1, &textures.back().id);
    textures.pop_back();
  }
  return id;
}

int ShaderKey(int mode, int alpha_mode, const GLuint (&textures)[5], bool labels) {
  int key = mode | alpha_mode << 3 | (labels ? 1 << 10 : 0);
  for (int unit = 0; unit < 5; ++unit) key |= textures[unit] ? 1 << (5 + unit) : 0;
  return key;
}

int RasterThreads() {
  return static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 16u));
}

namespace {

// The process's threads whose name starts with "llvmpipe-" (llvmpipe names its rasteriser threads
// so).
std::vector<pid_t> FindRasterThreads() {
  std::vector<pid_t> out;
  DIR* dir = opendir("/proc/self/task");
  if (!dir) return out;
  while (const dirent* e = readdir(dir)) {
    if (e->d_name[0] < '0' || e->d_name[0] > '9') continue;
    char comm[32] = {};
    const std::string path = std::string("/proc/self/task/") + e->d_name + "/comm";
    if (FILE* f = std::fopen(path.c_str(), "r")) {
      if (std::fgets(comm, sizeof comm, f) && std::strncmp(comm, "llvmpipe-", 9) == 0)
        out.push_back(static_cast<pid_t>(std::atoi(e->d_name)));
      std::fclose(f);
    }
  }
  closedir(dir);
  return out;
}

}  // namespace

double RasterCpu() {
  // Found once the first context made them (they live as long as the process's llvmpipe screen).
  static std::mutex mu;
  static std::vector<pid_t> tids;
  std::vector<pid_t> now;
  {
    std::lock_guard<std::mutex> lock(mu);
    if (tids.empty()) tids = FindRasterThreads();
    now = tids;
  }
  double sum = 0.0;
  for (pid_t t : now) sum += ThreadCpuSeconds(t);
  return sum;
}

}  // namespace facespace::offscreen
