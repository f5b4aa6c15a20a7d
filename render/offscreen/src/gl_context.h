// The GL side of the OSMesa renderer: one context's objects (shaders, targets, textures) and the
// pool of contexts every thread shares (render.cpp draws with them; the shaders are in
// gl_context.cpp).
#pragma once
#include <GL/gl.h>
#include <GL/glext.h>
#include <GL/osmesa.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "facespace/engine/cpu.h"
#include "facespace/offscreen/render.h"

namespace facespace::offscreen {

// The key of an encoded image: the whole file up to 64 KB, else its first and last 32 KB (a PNG's
// ends hold the checksums of all its pixels) and every 61st 8-byte word between, mixed eight
// bytes at a time (FaceCap's 330 KB texture: 29 us a render, byte by byte 78 us). Sampling alone
// gave two small flat-colour PNGs of the same length the same key (the second drew with the first's
// colour).
uint64_t TextureKey(std::span<const unsigned char> bytes, bool srgb_data);

struct Texture {
  uint64_t key;
  GLuint id;
};

// Everything GL of one context. Current on one thread at a time: the thread that leased it.
struct GlContext {
  OSMesaContext ctx = nullptr;
  std::vector<unsigned char> dummy = std::vector<unsigned char>(16 * 16 * 4);
  GLuint vertex_shader = 0, vao = 0, vbo = 0, ibo = 0;
  std::vector<std::pair<int, GLuint>> programs;  // By ShaderKey, linked on first use.
  // Two render targets, kept apart so that renders of either kind never rebuild the other's: linear
  // floats (RGBA32F), and 8-bit sRGB (SRGB8_ALPHA8) for pictures that only go to 8-bit files.
  struct Target {
    GLuint fbo = 0, color = 0, depth = 0;
    GLuint labels[2] = {0, 0};  // RGBA32F distance and normal, R32F segment: RenderOptions::labels,
                                // made when first asked.
    int w = 0, h = 0;
  };
  Target targets[2];
  bool pack_invert = false;     // GL_MESA_pack_invert: glReadPixels can give the rows top first.
  std::list<Texture> textures;  // Most recent first; a few kept.
  // The last render's vertex arrays and read-back, kept so that a render of a size seen
  // before allocates nothing (a 512x512 read-back is 4 MB of floats: new pages each time).
  std::vector<float> verts, pixels;
  std::vector<uint32_t> indices;
  std::string error;
  std::string info;

  ~GlContext();

  // Creates the context and makes it current on the calling thread.
  bool Init();

  bool MakeCurrent();

  GLuint Compile(GLenum type, const char* src);

  // The fragment program of one variant (ShaderKey), compiled and linked on first use; 0 and
  // `error` when it fails.
  GLuint Program(int key);

  // After a large render (over 1024 x 1024 samples: 20 bytes a sample in the targets, 16 in the
  // read-back) its targets and read-back are let go, so a context does not keep hundreds of
  // megabytes, or gigabytes, for the next, likely smaller, render.
  void TrimLarge();
  void FreeTarget(Target& t);  // Its framebuffer and renderbuffers deleted, emptied.

  // Binds the target of that kind (srgb8: 8-bit sRGB, else float), made or resized to w x h,
  // drawing to its colour and, with `labels`, to its two label planes too (attachments 1 and 2).
  void BindTarget(int w, int h, bool srgb8, bool labels = false);

  // The GL texture of an encoded image, decoded once per thread (a few kept).
  // Colour maps are sRGB (sampled as linear), data maps (normals, roughness, occlusion) linear.
  GLuint TextureFor(const facespace::Image& image, bool srgb_data);
};

// A fragment program variant (GlContext::Program): the mode in bits 0-2, the alpha mode in 3-4,
// then a bit per texture the material has (base colour, metal-rough, normal, occlusion, emissive),
// then whether it writes the label planes.
int ShaderKey(int mode, int alpha_mode, const GLuint (&textures)[5], bool labels = false);

// llvmpipe's rasteriser threads per context: one per core, at most 16 (llvmpipe's own limit).
int RasterThreads();
// The CPU-seconds llvmpipe's rasteriser threads have spent, all of them: one set serves every
// context of the process, so each lease is charged (ChargeHelperCpu) what they spent while it was
// held, shared among the leases held meanwhile.
double RasterCpu();

// The GL contexts of one renderer, shared by every thread that draws with it. A render leases one
// for its whole run (vertex arrays, draw, read-back), so at most `limit` renders hold that memory
// at once, about 20 MB each at 1024 x 1024 samples, however many threads serve requests; the rest
// wait their turn. With llvmpipe rasterising each draw on every core, more contexts than cores
// would not draw faster.
class OsMesaRenderer::ContextPool {
 public:
  class Lease {
   public:
    Lease(ContextPool* pool, std::unique_ptr<GlContext> context, HelperCpu* helper_cpu)
        : pool_(pool),
          context_(std::move(context)),
          helper_cpu_(helper_cpu),
          held_with_(++pool->leased_),
          raster_mark_(RasterCpu()) {}
    Lease(Lease&& o) noexcept
        : pool_(o.pool_),
          context_(std::move(o.context_)),
          helper_cpu_(o.helper_cpu_),
          held_with_(o.held_with_),
          raster_mark_(o.raster_mark_) {}
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (!context_) return;
      // The rasteriser's CPU while this lease was held, its share of it charged to the work it drew
      // for.
      const int now = pool_->leased_--;
      ChargeHelperCpu(helper_cpu_,
                      (RasterCpu() - raster_mark_) / std::max(1.0, 0.5 * (held_with_ + now)));
      pool_->Release(std::move(context_));
    }
    GlContext* get() const { return context_.get(); }

   private:
    ContextPool* pool_;
    std::unique_ptr<GlContext> context_;
    HelperCpu* helper_cpu_;   // Charged the rasteriser's CPU for this lease (null: nowhere).
    int held_with_ = 1;       // Leases held when this one began, itself included.
    double raster_mark_ = 0;  // RasterCpu() then.
  };

  // A context current on this thread, or the reason there is none; its lease charges `helper_cpu`.
  Result<Lease> Acquire(HelperCpu* helper_cpu = nullptr) {
    std::unique_ptr<GlContext> context;
    {
      // First come, first served: a ticket each, so no render waits behind later ones.
      std::unique_lock lock(mu_);
      const uint64_t ticket = next_ticket_++;
      cv_.wait(lock, [this, ticket] {
        return ticket == serving_ && (!idle_.empty() || live_ < Limit());
      });
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
      if (context->MakeCurrent()) return Lease(this, std::move(context), helper_cpu);
      Discard();
      return Internal("renderer unavailable: " + context->error);
    }
    // llvmpipe rasterises each draw on one thread per core (unless LP_NUM_THREADS says otherwise):
    // faster than drawing on the calling thread (LP_NUM_THREADS=0), alone and under load
    // (figures in tests/bench/README.md).
    std::call_once(env_once_,
                   [] { setenv("LP_NUM_THREADS", std::to_string(RasterThreads()).c_str(), 0); });
    context = std::make_unique<GlContext>();
    if (context->Init()) return Lease(this, std::move(context), helper_cpu);
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
  void Release(std::unique_ptr<GlContext> context) {
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
  std::atomic<int> leased_{0};  // Leases held now.
  std::vector<std::unique_ptr<GlContext>> idle_;
  int live_ = 0;   // Contexts created and not destroyed: idle or leased.
  int limit_ = 0;  // 0: one per core.
  const int cores_ =
      std::max(1, static_cast<int>(std::thread::hardware_concurrency()));  // Asked once: a syscall.
  uint64_t next_ticket_ = 0, serving_ = 0;
  std::once_flag env_once_;
};

}  // namespace facespace::offscreen
