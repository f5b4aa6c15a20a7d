// Response compression, ours alone. cpp-httplib compresses a body afresh on every request, after
// the handler, at brotli's slowest quality and with no stop check (a 0.05-CPU-s answer took 88
// CPU-s with `Accept-Encoding: br`, and neither the meter nor the deadline could stop it): it never
// sees the client's Accept-Encoding (HideAcceptEncoding, at pre-routing). Instead:
// - what does not change between requests (a rig's topology, its description, the OpenAPI document)
// is
//   encoded once per version and coding (brotli at quality 5, or gzip at level 6), kept in the
//   response cache, and sent as it is (SendEncodedOnce);
// - any other body is encoded on the request's own worker (metered, stopped like the rest of its
// work)
//   at the fastest settings (brotli quality 1, gzip level 1) in 256 KB steps with a stop check
//   between them, and only up to kMaxDynamicCompressed bytes: a larger one goes as it is
//   (CompressBody).
#pragma once

#include <httplib.h>

#include <functional>
#include <stop_token>
#include <string>
#include <string_view>

#include "context.h"

namespace facespace::http {

enum class ContentCoding { kIdentity, kGzip, kBrotli };

// The request header the client's Accept-Encoding is moved to before cpp-httplib can act on it.
inline constexpr const char* kAcceptEncoding = "Facespace-Accept-Encoding";
// Moves Accept-Encoding out of cpp-httplib's sight (dropping any the client sent under our name).
void HideAcceptEncoding(httplib::Request& req);

// The largest body compressed per request; larger ones go uncompressed (brotli's quality 1 takes
// about 10 ms a MB here, so at most about 0.1 CPU-s).
inline constexpr size_t kMaxDynamicCompressed = size_t{8} << 20;
// A body under this size is not worth a coding.
inline constexpr size_t kMinCompressed = 1024;

// The coding to answer with, from Accept-Encoding: br, else gzip, else none (a coding with q=0 is
// refused).
ContentCoding PreferredCoding(const httplib::Request& req);
const char* CodingName(ContentCoding coding);  // "identity", "gzip", "br".

// `body` in `coding`; false when the encoder failed (the caller sends it as it is).
bool EncodeBody(std::string_view body, ContentCoding coding, std::string& out);
// The same at the fastest settings, in steps with `stop` checked between them; false when stopped
// or failed.
bool EncodeBodyFast(std::string_view body, ContentCoding coding, std::stop_token stop,
                    std::string& out);

// After a handler: the response's body, when it is text-like (JSON, text, SVG, XML, JavaScript), at
// least kMinCompressed and at most kMaxDynamicCompressed bytes, not yet encoded, and the client
// takes br or gzip, is encoded (EncodeBodyFast) with Content-Encoding and Vary set; otherwise left
// as it is.
void CompressBody(const httplib::Request& req, httplib::Response& res, std::stop_token stop);

// The body `produce()` makes for `key`, in `coding` (identity when the encoder failed), from the
// response cache or made and offered to it.
std::shared_ptr<const CachedResponse> EncodedOnce(ServerState& ctx, const std::string& key,
                                                  ContentCoding& coding, const char* content_type,
                                                  const std::function<std::string()>& produce);

// Sends the body `produce()` makes, for `key` (which must name the rig's version and whatever else
// the body depends on), in the client's preferred coding, from the response cache when it holds it:
// Content-Encoding, Vary: Accept-Encoding, an ETag per coding (If-None-Match answered 304).
void SendEncodedOnce(ServerState& ctx, const httplib::Request& req, httplib::Response& res,
                     const std::string& key, const char* content_type,
                     const std::function<std::string()>& produce);

}  // namespace facespace::http
