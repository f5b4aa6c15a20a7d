// The OpenImageIO module (see facespace/oiio/module.h): built as libfacespace_oiio.so, opened on
// first use.
#include "facespace/oiio/module.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <memory>
#include <mutex>

namespace facespace::oiio {

namespace {

bool Encode(const EncodeArgs& a, std::vector<unsigned char>* out, std::string* error) {
  OIIO::Filesystem::IOVecOutput proxy(*out);
  std::unique_ptr<OIIO::ImageOutput> writer =
      OIIO::ImageOutput::create(a.name, a.to_file ? nullptr : &proxy);
  if (!writer) {
    *error = std::string("no OpenImageIO writer for ") + a.name;
    return false;
  }
  bool ok;
  if (a.linear) {
    OIIO::ImageSpec spec(a.width, a.height, 4, OIIO::TypeDesc::HALF);
    if (a.zip) spec.attribute("compression", "zip");
    ok = writer->open(a.name, spec) && writer->write_image(OIIO::TypeDesc::FLOAT, a.linear) &&
         writer->close();
  } else {
    OIIO::ImageSpec spec(a.width, a.height, a.channels, OIIO::TypeDesc::UINT8);
    spec.attribute("oiio:ColorSpace", "sRGB");
    if (a.quality > 0) spec.attribute("CompressionQuality", a.quality);
    if (a.zip) spec.attribute("compression", "zip");
    ok = writer->open(a.name, spec) && writer->write_image(OIIO::TypeDesc::UINT8, a.srgb8) &&
         writer->close();
  }
  if (!ok) *error = writer->geterror();
  return ok;
}

bool Decode(const unsigned char* bytes, size_t size, const char* name, int max_side, Decoded* out,
            std::string* error) {
  // One decode at a time: two render threads opening the same JPEG at once crashed inside
  // OpenImageIO 2.4 (a SEGV in decode_icc_profile, a double free under ASan: batch workers resuming
  // a job, each GL context decoding FaceCap's texture). A texture is decoded once per context, so
  // this costs little.
  static std::mutex one_at_a_time;
  std::lock_guard<std::mutex> lock(one_at_a_time);
  OIIO::Filesystem::IOMemReader proxy(bytes, size);
  auto in = OIIO::ImageInput::open(name, nullptr, &proxy);
  if (!in) {
    *error = "cannot decode the image: " + OIIO::geterror();
    return false;
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width < 1 || spec.height < 1 || spec.width > max_side || spec.height > max_side ||
      spec.nchannels < 1) {
    *error = "image size out of range";
    return false;
  }
  out->width = spec.width;
  out->height = spec.height;
  out->channels = spec.nchannels;
  out->pixels.resize(static_cast<size_t>(spec.width) * spec.height * spec.nchannels);
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, out->pixels.data())) {
    *error = "cannot decode the image: " + in->geterror();
    return false;
  }
  return true;
}

constexpr Api kApi{Encode, Decode};

}  // namespace

}  // namespace facespace::oiio

// OpenImageIO and OpenEXR work on the calling thread (issue 61): their pools' threads (one per core
// each) spent a sheet's EXR compression where the request's meter did not see it (1.2 CPU-s of an
// EXR sheet's 6). A render or sheet is one request's work on one worker; requests run side by side
// already.
extern "C" const facespace::oiio::Api* facespace_oiio_api() {
  static const bool single = [] {
    OIIO::attribute("threads", 1);
    OIIO::attribute("exr_threads", -1);  // -1: OpenEXR without a thread pool.
    return true;
  }();
  (void)single;
  return &facespace::oiio::kApi;
}
