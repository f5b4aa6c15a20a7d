// OSMesa (llvmpipe) renderer: a bounded pool of GL 3.3 core contexts shared by every thread,
// an offscreen float framebuffer, glTF metallic-roughness under a studio light in linear light,
// tone mapped (Khronos PBR Neutral).
#define GL_GLEXT_PROTOTYPES 1
#include "facespace/render/render.h"
#include "facespace/core/enum_table.h"
#include "facespace/core/hierarchy.h"

#include "facespace/core/shape_tools.h"
#include "facespace/core/transform.h"
#include "internal.h"

#include <GL/osmesa.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstring>
#include <algorithm>
#include <condition_variable>
#include <cstdlib>
#include <list>
#include <memory>
#include <mutex>
#include <thread>

namespace facespace::render {

namespace {

const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 a_pos;
layout(location = 1) in vec3 a_normal;
layout(location = 2) in vec2 a_uv;
layout(location = 3) in vec4 a_color;
layout(location = 4) in float a_scalar;
uniform mat4 u_view;
uniform mat4 u_proj;
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
  gl_Position = u_proj * p;
}
)";

// One program per variant (Context::Program): MODE (0 shaded with the material, 1 flat colour,
// 2 heatmap, 3 normals, 4 clay), ALPHA_MODE (0 opaque, 1 mask, 2 blend) and HAS_* (the material's
// textures) are defined before this text. llvmpipe runs both sides of every branch with masks,
// so one program branching on uniforms paid for every mode and every texture on each fragment.
const char* kFragmentShader = R"(
in vec3 v_pos;
in vec3 v_normal;
in vec3 v_world_normal;
in vec2 v_uv;
in vec4 v_color;
in float v_scalar;
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
out vec4 frag;
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
    vec3 l = normalize(dirs[i]);
    float nl = dot(n, l);
    if (nl <= 0.0) continue;
    vec3 h = normalize(l + v);
    float nh = max(dot(n, h), 0.0), vh = max(dot(v, h), 0.0);
    float q = nh * nh * (a2 - 1.0) + 1.0;
    float D = a2 / (PI * q * q);
    float V = 0.5 / (nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2));
    vec3 F = f0 + (1.0 - f0) * pow(1.0 - vh, 5.0);
    color += ((1.0 - F) * diffuse / PI + D * V * F) * radiance[i] * nl;
  }
  vec3 ambient = mix(floor_, sky, n.y * 0.5 + 0.5);
  vec3 r = reflect(-v, n);
  vec3 reflected = mix(floor_, sky, clamp(r.y * 0.5 + 0.5, 0.0, 1.0));
  color += occlusion * (ambient * diffuse + reflected * env_brdf(f0, rough, nv));
  return STUDIO_LEVEL * color;
}
void main() {
  vec3 n = normalize(v_normal);
  if (!gl_FrontFacing) n = -n;
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
}
)";

// The key of an encoded image: the whole file up to 64 KB, else its first and last 32 KB (a PNG's
// ends hold the checksums of all its pixels) and every 61st 8-byte word between, mixed eight
// bytes at a time (FaceCap's 330 KB texture: 29 us a render, byte by byte 78 us). Sampling alone gave two small
// flat-colour PNGs of the same length the same key (the second drew with the first's colour).
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

struct Texture {
  uint64_t key;
  GLuint id;
};

// Everything GL of one context. Current on one thread at a time: the thread that leased it.
struct Context {
  OSMesaContext ctx = nullptr;
  std::vector<unsigned char> dummy = std::vector<unsigned char>(16 * 16 * 4);
  GLuint vertex_shader = 0, vao = 0, vbo = 0, ibo = 0;
  std::vector<std::pair<int, GLuint>> programs;  // By ShaderKey, linked on first use.
  // Two render targets, kept apart so that renders of either kind never rebuild the other's: linear
  // floats (RGBA32F), and 8-bit sRGB (SRGB8_ALPHA8) for pictures that only go to 8-bit files.
  struct Target {
    GLuint fbo = 0, color = 0, depth = 0;
    int w = 0, h = 0;
  };
  Target targets[2];
  bool pack_invert = false;  // GL_MESA_pack_invert: glReadPixels can give the rows top first.
  std::list<Texture> textures;  // Most recent first; a few kept.
  // The last render's vertex arrays and read-back, kept so that a render of a size seen
  // before allocates nothing (a 512x512 read-back is 4 MB of floats: new pages each time).
  std::vector<float> verts, pixels;
  std::vector<uint32_t> indices;
  std::string error;
  std::string info;

  ~Context() {
    if (ctx) OSMesaDestroyContext(ctx);
  }

  // Creates the context and makes it current on the calling thread.
  bool Init() {
    const int attribs[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 24, OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION, 3, OSMESA_CONTEXT_MINOR_VERSION, 3, 0};
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
      if (std::strcmp(reinterpret_cast<const char*>(glGetStringi(GL_EXTENSIONS, static_cast<GLuint>(i))), "GL_MESA_pack_invert") == 0) pack_invert = true;
    }
    vertex_shader = Compile(GL_VERTEX_SHADER, kVertexShader);
    if (!vertex_shader || !Program(0)) return false;  // The shaded, untextured variant: every render's first.
    glGenVertexArrays(1, &vao);
    glGenBuffers(1, &vbo);
    glGenBuffers(1, &ibo);
    return true;
  }

  bool MakeCurrent() {
    if (OSMesaMakeCurrent(ctx, dummy.data(), GL_UNSIGNED_BYTE, 16, 16)) return true;
    error = "OSMesaMakeCurrent failed";
    return false;
  }

  GLuint Compile(GLenum type, const char* src) {
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
  GLuint Program(int key) {
    for (const auto& [k, p] : programs) {
      if (k == key) return p;
    }
    const std::string defines = "#version 330 core\n#define MODE " + std::to_string(key & 7) + "\n#define ALPHA_MODE " +
                                std::to_string((key >> 3) & 3) + "\n#define HAS_TEXTURE " + std::to_string((key >> 5) & 1) +
                                "\n#define HAS_METAL_ROUGH " + std::to_string((key >> 6) & 1) + "\n#define HAS_NORMAL_MAP " +
                                std::to_string((key >> 7) & 1) + "\n#define HAS_OCCLUSION " + std::to_string((key >> 8) & 1) +
                                "\n#define HAS_EMISSIVE " + std::to_string((key >> 9) & 1) + "\n";
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
  void TrimLarge() {
    constexpr long long kKept = 1024LL * 1024;
    for (Target& t : targets) {
      if (t.fbo && static_cast<long long>(t.w) * t.h > kKept) {
        glDeleteFramebuffers(1, &t.fbo);
        glDeleteRenderbuffers(1, &t.color);
        glDeleteRenderbuffers(1, &t.depth);
        t = Target{};
      }
    }
    if (pixels.capacity() > static_cast<size_t>(kKept) * 4) std::vector<float>().swap(pixels);
  }

  // Binds the target of that kind (srgb8: 8-bit sRGB, else float), made or resized to w x h.
  void BindTarget(int w, int h, bool srgb8) {
    Target& t = targets[srgb8 ? 1 : 0];
    if (w != t.w || h != t.h || !t.fbo) {
      if (t.fbo) {
        glDeleteFramebuffers(1, &t.fbo);
        glDeleteRenderbuffers(1, &t.color);
        glDeleteRenderbuffers(1, &t.depth);
      }
      glGenFramebuffers(1, &t.fbo);
      glBindFramebuffer(GL_FRAMEBUFFER, t.fbo);
      glGenRenderbuffers(1, &t.color);
      glBindRenderbuffer(GL_RENDERBUFFER, t.color);
      glRenderbufferStorage(GL_RENDERBUFFER, srgb8 ? GL_SRGB8_ALPHA8 : GL_RGBA32F, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, t.color);
      glGenRenderbuffers(1, &t.depth);
      glBindRenderbuffer(GL_RENDERBUFFER, t.depth);
      glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT24, w, h);
      glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, t.depth);
      t.w = w;
      t.h = h;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, t.fbo);
    // Shader outputs are linear: GL converts them (and the clear colour, and blends) to sRGB at the store.
    if (srgb8) glEnable(GL_FRAMEBUFFER_SRGB);
    else glDisable(GL_FRAMEBUFFER_SRGB);
  }

  // The GL texture of an encoded image, decoded once per thread (a few kept).
  // Colour maps are sRGB (sampled as linear), data maps (normals, roughness, occlusion) linear.
  GLuint TextureFor(const facespace::Image& image, bool srgb_data) {
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
    const render::Image& im = decoded.value();
    std::vector<unsigned char> srgb(im.rgba.size());  // The file's own 8-bit values (Decode made them linear).
    for (size_t i = 0; i < im.rgba.size(); ++i) {
      const float c = im.rgba[i];
      const float e = (i % 4 == 3) ? c : (c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1 / 2.4f) - 0.055f);
      srgb[i] = static_cast<unsigned char>(std::lround(std::clamp(e, 0.0f, 1.0f) * 255.0f));
    }
    GLuint id = 0;
    glGenTextures(1, &id);
    glBindTexture(GL_TEXTURE_2D, id);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, srgb_data ? GL_SRGB8_ALPHA8 : GL_RGBA8, im.width, im.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, srgb.data());
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
};

float SrgbToLinear(float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); }

// A fragment program variant (Context::Program): the mode in bits 0-2, the alpha mode in 3-4,
// then a bit per texture the material has (base colour, metal-rough, normal, occlusion, emissive).
int ShaderKey(int mode, int alpha_mode, const GLuint (&textures)[5]) {
  int key = mode | alpha_mode << 3;
  for (int unit = 0; unit < 5; ++unit) key |= textures[unit] ? 1 << (5 + unit) : 0;
  return key;
}

// llvmpipe's rasteriser threads per context: one per core, at most 16 (llvmpipe's own limit).
int RasterThreads() { return static_cast<int>(std::clamp(std::thread::hardware_concurrency(), 1u, 16u)); }

}  // namespace

// The GL contexts of one renderer, shared by every thread that draws with it. A render leases one for its whole run (vertex arrays,
// draw, read-back), so at most `limit` renders hold that memory at once, about 20 MB each at
// 1024 x 1024 samples, however many threads serve requests; the rest wait their turn. With
// llvmpipe rasterising each draw on every core, more contexts than cores would not draw faster.
class OsMesaRenderer::ContextPool {
 public:
  class Lease {
   public:
    Lease(ContextPool* pool, std::unique_ptr<Context> context) : pool_(pool), context_(std::move(context)) {}
    Lease(Lease&&) = default;
    ~Lease() {
      if (context_) pool_->Release(std::move(context_));
    }
    Context* get() const { return context_.get(); }

   private:
    ContextPool* pool_;
    std::unique_ptr<Context> context_;
  };

  // A context current on this thread, or the reason there is none.
  Result<Lease> Acquire() {
    std::unique_ptr<Context> context;
    {
      // First come, first served: a ticket each, so no render waits behind later ones.
      std::unique_lock lock(mu_);
      const uint64_t ticket = next_ticket_++;
      cv_.wait(lock, [this, ticket] { return ticket == serving_ && (!idle_.empty() || live_ < Limit()); });
      ++serving_;
      cv_.notify_all();  // The next ticket may go too if another context is free.
      if (!idle_.empty()) {
        context = std::move(idle_.back());
        idle_.pop_back();
      } else {
        ++live_;
      }
    }
    if (context) {
      if (context->MakeCurrent()) return Lease(this, std::move(context));
      Discard();
      return Internal("renderer unavailable: " + context->error);
    }
    // llvmpipe rasterises each draw on one thread per core (unless LP_NUM_THREADS says otherwise):
    // faster than drawing on the calling thread (LP_NUM_THREADS=0), alone and under load
    // (figures in tests/bench/README.md).
    std::call_once(env_once_, [] { setenv("LP_NUM_THREADS", std::to_string(RasterThreads()).c_str(), 0); });
    context = std::make_unique<Context>();
    if (context->Init()) return Lease(this, std::move(context));
    const std::string error = context->error;
    context.reset();
    Discard();
    return Internal("renderer unavailable: " + error);
  }

  void SetLimit(int n) {
    std::lock_guard lock(mu_);
    limit_ = n;
    while (live_ > Limit() && !idle_.empty()) {
      idle_.pop_back();
      --live_;
    }
    cv_.notify_all();
  }

  int Limit() const { return limit_ > 0 ? limit_ : cores_; }

 private:
  void Release(std::unique_ptr<Context> context) {
    OSMesaMakeCurrent(nullptr, nullptr, 0, 0, 0);  // Free to be made current on another thread.
    std::lock_guard lock(mu_);
    if (live_ > Limit()) {
      context.reset();
      --live_;
    } else {
      idle_.push_back(std::move(context));
    }
    cv_.notify_all();
  }

  void Discard() {
    std::lock_guard lock(mu_);
    --live_;
    cv_.notify_all();
  }

  std::mutex mu_;
  std::condition_variable cv_;
  std::vector<std::unique_ptr<Context>> idle_;
  int live_ = 0;    // Contexts created and not destroyed: idle or leased.
  int limit_ = 0;   // 0: one per core.
  const int cores_ = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));  // Asked once: a syscall.
  uint64_t next_ticket_ = 0, serving_ = 0;
  std::once_flag env_once_;
};


namespace {
constexpr EnumName<View> kViews[] = {
    {View::kShaded, "shaded"}, {View::kWireframe, "wireframe"}, {View::kHeatmap, "heatmap"}, {View::kNormals, "normals"},
    {View::kClay, "clay"}};
}  // namespace

bool ParseView(const std::string& name, View* view) { return ParseEnum(kViews, name, view); }
const char* ViewName(View view) { return EnumEntry(kViews, view).name; }

OsMesaRenderer::OsMesaRenderer(int max_contexts) : pool_(std::make_unique<ContextPool>()) { pool_->SetLimit(max_contexts); }
OsMesaRenderer::~OsMesaRenderer() = default;

std::string OsMesaRenderer::Info() const {
  auto lease = pool_->Acquire();
  if (!lease.ok()) return "unavailable: " + lease.status().message;
  return lease.value().get()->info;
}

void OsMesaRenderer::SetMaxContexts(int n) { pool_->SetLimit(n); }

int OsMesaRenderer::Concurrency() const { return pool_->Limit(); }

Status CheckDrawInputs(const Rig& rig, const BlendedRig& blended, const RenderOptions& o) {
  if (o.width < 1 || o.height < 1 || o.width > 8192 || o.height > 8192) return InvalidArgument("image size out of range");
  if (o.supersample < 1 || o.supersample > 4) return InvalidArgument("supersample must be 1..4");
  if (blended.primitives.size() != rig.primitives.size()) return InvalidArgument("blended rig does not match the rig");
  return Status::Ok();
}

Status NullRenderer::Draw(const Rig& rig, const BlendedRig& blended, const RenderOptions& o, Image& out) const {
  if (Status s = CheckDrawInputs(rig, blended, o); !s.ok()) return s;
  out.width = o.width;
  out.height = o.height;
  out.srgb8.clear();
  out.rgba.resize(static_cast<size_t>(o.width) * o.height * 4);
  for (size_t i = 0; i < out.rgba.size(); i += 4) {
    for (int c = 0; c < 3; ++c) out.rgba[i + c] = SrgbToLinear(o.background[c]);
    out.rgba[i + 3] = o.background[3];
  }
  return Status::Ok();
}

Status OsMesaRenderer::Draw(const Rig& rig, const BlendedRig& blended, const RenderOptions& o, Image& out) const {
  if (Status s = CheckDrawInputs(rig, blended, o); !s.ok()) return s;
  // A context from the pool for the whole render: the vertex arrays and the read-back below
  // then exist for at most Concurrency() renders at once, however many requests wait.
  auto lease = pool_->Acquire();
  if (!lease.ok()) return lease.status();
  Context& gl = *lease.value().get();
  const int w = o.width * o.supersample, h = o.height * o.supersample;
  struct Trim {  // Before the lease lets the context go: it is still current here.
    Context& gl;
    ~Trim() { gl.TrimLarge(); }
  } trim{gl};

  // World-space vertices: pos, normal, uv, colour, displacement (13 floats).
  struct Draw {
    size_t first_vertex, first_index, index_count;
    PrimitiveMode mode;
    int material;
  };
  std::vector<float>& verts = gl.verts;
  std::vector<uint32_t>& indices = gl.indices;
  verts.clear();
  indices.clear();
  std::vector<Draw> draws;
  Eigen::AlignedBox3f box, shape_box, rest_box, joint_box;
  float heat_max = 0.0f;

  // frame=joint:NAME: the node, and per skin its index among the skin's joints (-1: not in it).
  int joint_node = -1;
  std::vector<int> joint_in_skin(rig.skins.size(), -1);
  if (o.camera.frame == Framing::kJoint) {
    joint_node = FindNode(rig, o.camera.frame_joint);
    std::vector<std::string_view> names;
    for (const Skin& skin : rig.skins) {
      for (int j : skin.joints) names.push_back(rig.nodes[static_cast<size_t>(j)].name);
    }
    if (names.empty()) return InvalidArgument("frame: joint:" + o.camera.frame_joint + ": the rig has no skeleton");
    if (joint_node < 0) {
      return InvalidArgument("frame: no joint '" + o.camera.frame_joint + "' in the rig" + DidYouMean(o.camera.frame_joint, names));
    }
    for (size_t s = 0; s < rig.skins.size(); ++s) {
      const auto& joints = rig.skins[s].joints;
      const auto it = std::find(joints.begin(), joints.end(), joint_node);
      if (it != joints.end()) joint_in_skin[s] = static_cast<int>(it - joints.begin());
    }
  }

  for (size_t pi = 0; pi < rig.primitives.size(); ++pi) {
    const Primitive& p = rig.primitives[pi];
    const BlendedPrimitive& b = blended.primitives[pi];
    const int skin = p.mesh >= 0 && static_cast<size_t>(p.mesh) < rig.meshes.size() ? rig.meshes[static_cast<size_t>(p.mesh)].skin : -1;
    const int joint = skin >= 0 && static_cast<size_t>(skin) < joint_in_skin.size() ? joint_in_skin[static_cast<size_t>(skin)] : -1;

    const auto& m = b.world;
    Eigen::Matrix3f nm = Eigen::Map<const Eigen::Matrix4f>(m.data()).topLeftCorner<3, 3>().inverse().transpose();
    const size_t first = verts.size() / 13;
    for (size_t v = 0; v < p.vertex_count(); ++v) {
      float q[3], rest[3], moved[3];
      TransformPoint(m, &b.positions[3 * v], q);
      // The rest shape, for a camera that does not move with the weights (a skinned primitive's
      // positions are in scene space already).
      if (b.skinned) std::copy(q, q + 3, rest);
      else TransformPoint(m, &p.positions[3 * v], rest);
      // Displacement by the shapes: world space, or for skinned primitives the morph in
      // mesh space (the skeleton's motion is not the shapes').
      for (int c = 0; c < 3; ++c) moved[c] = b.skinned ? b.morphed_positions[3 * v + c] - p.positions[3 * v + c] : q[c] - rest[c];
      Eigen::Vector3f n = (nm * Eigen::Map<const Eigen::Vector3f>(&b.normals[3 * v])).normalized();
      if (!n.allFinite()) n = Eigen::Vector3f::UnitZ();
      const float d = std::sqrt(moved[0] * moved[0] + moved[1] * moved[1] + moved[2] * moved[2]);
      heat_max = std::max(heat_max, d);
      box.extend(Eigen::Vector3f(q[0], q[1], q[2]));
      if (!blended.posed) rest_box.extend(Eigen::Vector3f(rest[0], rest[1], rest[2]));
      // The vertices the framed joint carries (a third of their weight or more), where the pose puts them.
      if (joint >= 0 && p.influences > 0) {
        for (size_t k = 0; k < p.influences; ++k) {
          const size_t at = v * p.influences + k;
          if (p.joints[at] == joint && p.joint_weights[at] >= 1.0f / 3.0f) {
            joint_box.extend(Eigen::Vector3f(q[0], q[1], q[2]));
            break;
          }
        }
      }
      const float uv[2] = {p.texcoords.empty() ? 0.0f : p.texcoords[2 * v], p.texcoords.empty() ? 0.0f : p.texcoords[2 * v + 1]};
      verts.insert(verts.end(), {q[0], q[1], q[2], n.x(), n.y(), n.z(), uv[0], uv[1]});
      if (p.colors.empty()) verts.insert(verts.end(), {1.0f, 1.0f, 1.0f, 1.0f});
      else verts.insert(verts.end(), p.colors.begin() + 4 * v, p.colors.begin() + 4 * v + 4);
      verts.push_back(d);
    }
    draws.push_back({first, indices.size(), p.indices.size(), p.mode, p.material});
    for (uint32_t i : p.indices) indices.push_back(static_cast<uint32_t>(first + i));
  }

  // Framing the shapes: the rest-pose box of what they move (stable while sliders move).
  bool frame_shapes = false;
  if (o.camera.frame == Framing::kAuto || o.camera.frame == Framing::kShapes) {
    std::array<float, 3> lo = o.camera.focus_min, hi = o.camera.focus_max;
    const bool found = o.camera.has_focus || ShapeFocusBox(rig, lo, hi);
    const bool small = o.camera.has_focus ? o.camera.focus_small : found && FrameShapesByDefault(rig, lo, hi);
    if (found) {
      frame_shapes = o.camera.frame == Framing::kShapes || small;
      shape_box = Eigen::AlignedBox3f(Eigen::Vector3f(lo[0], lo[1], lo[2]), Eigen::Vector3f(hi[0], hi[1], hi[2]));
    }
  }

  // A joint no vertex follows (a root, an end site): its position, in a tenth of the whole.
  if (joint_node >= 0 && joint_box.isEmpty()) {
    const auto& world = static_cast<size_t>(joint_node) < blended.node_world.size() ? blended.node_world[static_cast<size_t>(joint_node)]
                                                                                    : std::array<float, 16>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
    const Eigen::Vector3f at(world[12], world[13], world[14]);
    const float r = box.isEmpty() ? 0.1f : 0.05f * box.diagonal().norm();
    joint_box.extend(at - Eigen::Vector3f::Constant(r));
    joint_box.extend(at + Eigen::Vector3f::Constant(r));
  }

  // Camera.
  const Camera& c = o.camera;
  const Eigen::AlignedBox3f& whole = !blended.posed && !rest_box.isEmpty() ? rest_box : box;
  const Eigen::AlignedBox3f& framed = joint_node >= 0 ? joint_box : frame_shapes && !shape_box.isEmpty() ? shape_box : whole;
  const Eigen::Vector3f center = framed.isEmpty() ? Eigen::Vector3f(Eigen::Vector3f::Zero()) : Eigen::Vector3f(framed.center());
  const float radius = framed.isEmpty() ? 1.0f : std::max(0.5f * framed.diagonal().norm(), 1e-6f);
  const float fov = std::clamp(c.fov, 1.0f, 170.0f) * static_cast<float>(M_PI) / 180.0f;
  const float aspect = static_cast<float>(o.width) / static_cast<float>(o.height);
  Eigen::Vector3f eye, target, up;
  if (c.look_at) {
    eye = Eigen::Vector3f(c.eye[0], c.eye[1], c.eye[2]);
    target = Eigen::Vector3f(c.target[0], c.target[1], c.target[2]);
    up = Eigen::Vector3f(c.up[0], c.up[1], c.up[2]);
  } else {
    // Far enough that the bounding sphere fits both the vertical and horizontal field of view.
    const float fit = radius / std::sin(0.5f * std::min(fov, 2.0f * std::atan(std::tan(0.5f * fov) * aspect)));
    const float dist = (c.distance > 0 ? c.distance : fit) / std::max(c.zoom, 1e-3f);
    const float yaw = c.yaw * static_cast<float>(M_PI) / 180.0f, pitch = c.pitch * static_cast<float>(M_PI) / 180.0f;
    eye = center + dist * Eigen::Vector3f(std::cos(pitch) * std::sin(yaw), std::sin(pitch), std::cos(pitch) * std::cos(yaw));
    target = center;
    up = Eigen::Vector3f::UnitY();
  }
  Eigen::Vector3f fwd = (target - eye);
  if (fwd.norm() < 1e-12f) return InvalidArgument("camera eye and target coincide");
  fwd.normalize();
  Eigen::Vector3f right = fwd.cross(up);
  if (right.norm() < 1e-6f) right = fwd.cross(Eigen::Vector3f::UnitZ());
  right.normalize();
  const Eigen::Vector3f cam_up = right.cross(fwd);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = right.transpose();
  view.block<1, 3>(1, 0) = cam_up.transpose();
  view.block<1, 3>(2, 0) = -fwd.transpose();
  view(0, 3) = -right.dot(eye);
  view(1, 3) = -cam_up.dot(eye);
  view(2, 3) = fwd.dot(eye);
  const float center_dist = (center - eye).dot(fwd);
  const float znear = std::max(center_dist - 2.0f * radius, center_dist * 1e-3f > 0 ? center_dist * 1e-3f : radius * 1e-3f);
  const float zfar = std::max(center_dist + 2.0f * radius, znear * 2.0f);
  const float f = 1.0f / std::tan(0.5f * fov);
  Eigen::Matrix4f proj = Eigen::Matrix4f::Zero();
  proj(0, 0) = f / aspect;
  proj(1, 1) = f;
  proj(2, 2) = (zfar + znear) / (znear - zfar);
  proj(2, 3) = 2.0f * zfar * znear / (znear - zfar);
  proj(3, 2) = -1.0f;

  // Straight to 8 bits where asked and nothing after the draw needs floats (the box filter of
  // supersamples, the heatmap's legend).
  const bool srgb8 = o.srgb8 && o.supersample == 1 && o.view != View::kHeatmap && gl.pack_invert;
  gl.BindTarget(w, h, srgb8);
  glViewport(0, 0, w, h);
  const auto& bg = o.background;
  glClearColor(SrgbToLinear(bg[0]), SrgbToLinear(bg[1]), SrgbToLinear(bg[2]), bg[3]);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glBindVertexArray(gl.vao);
  glBindBuffer(GL_ARRAY_BUFFER, gl.vbo);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(verts.size() * 4), verts.data(), GL_STREAM_DRAW);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, gl.ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(indices.size() * 4), indices.data(), GL_STREAM_DRAW);
  const GLsizei stride = 13 * 4;
  const int sizes[5] = {3, 3, 2, 4, 1}, offsets[5] = {0, 3, 6, 8, 12};
  for (int a = 0; a < 5; ++a) {
    glEnableVertexAttribArray(a);
    glVertexAttribPointer(a, sizes[a], GL_FLOAT, GL_FALSE, stride, reinterpret_cast<void*>(static_cast<uintptr_t>(offsets[a] * 4)));
  }
  const int mode = o.view == View::kHeatmap ? 2 : o.view == View::kNormals ? 3 : o.view == View::kClay ? 4 : 0;
  const float exposure = std::exp2(std::clamp(o.exposure, -10.0f, 10.0f));
  const char* samplers[5] = {"u_texture", "u_metal_rough_texture", "u_normal_texture", "u_occlusion_texture", "u_emissive_texture"};
  // A primitive with no material draws as light grey clay, not glTF's default (a rough metal, dark
  // without a detailed environment), so material-less meshes (OBJ, MakeHuman) read as shapes.
  Material none;
  none.base_color_factor = {0.8f, 0.8f, 0.8f, 1.0f};
  none.metallic_factor = 0.0f;
  none.roughness_factor = 0.5f;
  auto draw_all = [&](int shader_mode) -> Status {
    for (const Draw& d : draws) {
      const Material& mat = d.material >= 0 ? rig.materials[static_cast<size_t>(d.material)] : none;
      const auto& base = mat.base_color_factor;
      const bool blend = mat.alpha_mode == "BLEND";
      // The material's textures (clay, heatmap, normals and edges use none), each decoded before
      // any is bound: a decode binds on the active unit.
      const bool textured = shader_mode == 0;
      const int images[5] = {mat.base_color_image, mat.metallic_roughness_image, mat.normal_image, mat.occlusion_image, mat.emissive_image};
      const bool srgb[5] = {true, false, false, false, true};
      GLuint textures[5] = {};
      for (int unit = 0; textured && unit < 5; ++unit) {
        if (images[unit] >= 0) textures[unit] = gl.TextureFor(rig.images[static_cast<size_t>(images[unit])], srgb[unit]);
      }
      const int alpha_mode = !textured ? 0 : blend ? 2 : mat.alpha_mode == "MASK" ? 1 : 0;
      const GLuint program = gl.Program(ShaderKey(shader_mode, alpha_mode, textures));
      if (!program) return Internal("renderer: " + gl.error);
      glUseProgram(program);
      auto at = [program](const char* name) { return glGetUniformLocation(program, name); };
      glUniformMatrix4fv(at("u_view"), 1, GL_FALSE, view.data());
      glUniformMatrix4fv(at("u_proj"), 1, GL_FALSE, proj.data());
      glUniform1f(at("u_heat_max"), heat_max);
      glUniform1f(at("u_exposure"), exposure);
      glUniform4f(at("u_base_color"), base[0], base[1], base[2], base[3]);
      glUniform2f(at("u_metal_rough"), mat.metallic_factor, mat.roughness_factor);
      glUniform1f(at("u_normal_scale"), mat.normal_scale);
      glUniform1f(at("u_occlusion_strength"), mat.occlusion_strength);
      glUniform3f(at("u_emissive"), mat.emissive_factor[0], mat.emissive_factor[1], mat.emissive_factor[2]);
      glUniform1f(at("u_alpha_cutoff"), mat.alpha_cutoff);
      for (int unit = 0; unit < 5; ++unit) {
        glUniform1i(at(samplers[unit]), unit);
        glActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
        glBindTexture(GL_TEXTURE_2D, textures[unit]);
      }
      if (alpha_mode == 2) {
        glEnable(GL_BLEND);
        glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // "Over", alpha too.
      } else {
        glDisable(GL_BLEND);
      }
      const GLenum prim = d.mode == PrimitiveMode::kTriangles ? GL_TRIANGLES : d.mode == PrimitiveMode::kLines ? GL_LINES : GL_POINTS;
      glDrawElements(prim, static_cast<GLsizei>(d.index_count), GL_UNSIGNED_INT,
                     reinterpret_cast<void*>(static_cast<uintptr_t>(d.first_index * 4)));
    }
    return Status::Ok();
  };
  if (o.view == View::kWireframe) {
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1.0f, 1.0f);
  }
  Status drawn = draw_all(mode);
  glDisable(GL_POLYGON_OFFSET_FILL);
  if (o.view == View::kWireframe && drawn.ok()) {
    glPolygonMode(GL_FRONT_AND_BACK, GL_LINE);
    glDepthFunc(GL_LEQUAL);
    drawn = draw_all(1);
    glPolygonMode(GL_FRONT_AND_BACK, GL_FILL);
    glDepthFunc(GL_LESS);
  }
  if (!drawn.ok()) return drawn;
  const int ss = o.supersample;
  out.width = o.width;
  out.height = o.height;
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  // Straight into the image, top row first (MESA_pack_invert): no 4 MB copy to flip the rows.
  auto read_top_first = [w, h](GLenum type, void* data) {
    glPixelStorei(GL_PACK_INVERT_MESA, GL_TRUE);
    glReadPixels(0, 0, w, h, GL_RGBA, type, data);
    glPixelStorei(GL_PACK_INVERT_MESA, GL_FALSE);
    const GLenum err = glGetError();
    return err == GL_NO_ERROR ? Status::Ok() : Internal("GL error " + std::to_string(err));
  };
  if (srgb8) {
    // The stored sRGB bytes as they are (no conversion on the way out).
    glDisable(GL_FRAMEBUFFER_SRGB);
    out.rgba.clear();
    out.srgb8.resize(static_cast<size_t>(w) * h * 4);
    return read_top_first(GL_UNSIGNED_BYTE, out.srgb8.data());
  }
  out.srgb8.clear();
  if (ss == 1 && gl.pack_invert) {
    out.rgba.resize(static_cast<size_t>(w) * h * 4);
    if (Status s = read_top_first(GL_FLOAT, out.rgba.data()); !s.ok()) return s;
    if (o.view == View::kHeatmap) DrawHeatLegend(out, heat_max);
    return Status::Ok();
  }
  std::vector<float>& pixels = gl.pixels;
  pixels.resize(static_cast<size_t>(w) * h * 4);
  glReadPixels(0, 0, w, h, GL_RGBA, GL_FLOAT, pixels.data());
  if (const GLenum err = glGetError(); err != GL_NO_ERROR) {
    return Internal("GL error " + std::to_string(err));
  }
  // Box-filter the supersamples (in linear light) and flip to top-row-first.
  // Zeros where the supersamples add up; rows copied over whatever was there otherwise.
  if (ss > 1) out.rgba.assign(static_cast<size_t>(o.width) * o.height * 4, 0.0f);
  else out.rgba.resize(static_cast<size_t>(o.width) * o.height * 4);
  const float inv = 1.0f / static_cast<float>(ss * ss);
  for (int y = 0; ss == 1 && y < o.height; ++y) {  // No supersampling: rows flipped, as they are.
    std::memcpy(&out.rgba[static_cast<size_t>(y) * o.width * 4], &pixels[static_cast<size_t>(h - 1 - y) * w * 4], static_cast<size_t>(w) * 16);
  }
  for (int y = 0; ss > 1 && y < o.height; ++y) {
    for (int x = 0; x < o.width; ++x) {
      float* dst = &out.rgba[(static_cast<size_t>(y) * o.width + x) * 4];
      for (int sy = 0; sy < ss; ++sy) {
        const int gy = h - 1 - (y * ss + sy);
        for (int sx = 0; sx < ss; ++sx) {
          const float* src = &pixels[(static_cast<size_t>(gy) * w + x * ss + sx) * 4];
          for (int ch = 0; ch < 4; ++ch) dst[ch] += src[ch] * inv;
        }
      }
    }
  }
  if (o.view == View::kHeatmap) DrawHeatLegend(out, heat_max);
  return Status::Ok();
}

}  // namespace facespace::render
