// Bodies of what does not change between requests (a rig's topology, its description), encoded once
// per rig version and content coding: cpp-httplib brotli-compresses a body afresh on every request at
// brotli's slowest quality (uka's topology took 1.9 s a request). Here a body is made, encoded
// (brotli at quality 5, or gzip at level 6), kept in the response cache, and sent as it is.
#pragma once

#include <httplib.h>

#include <functional>
#include <string>
#include <string_view>

#include "context.h"

namespace facespace::api::http {

enum class ContentCoding { kIdentity, kGzip, kBrotli };

// The coding to answer with, from Accept-Encoding: br, else gzip, else none (a coding with q=0 is refused).
ContentCoding PreferredCoding(const httplib::Request& req);
const char* CodingName(ContentCoding coding);  // "identity", "gzip", "br".

// `body` in `coding`; false when the encoder failed (the caller sends it as it is).
bool EncodeBody(std::string_view body, ContentCoding coding, std::string& out);

// The body `produce()` makes for `key`, in `coding` (identity when the encoder failed), from the
// response cache or made and offered to it.
std::shared_ptr<const CachedResponse> EncodedOnce(ServerState& ctx, const std::string& key, ContentCoding& coding, const char* content_type,
                                                  const std::function<std::string()>& produce);

// Sends the body `produce()` makes, for `key` (which must name the rig's version and whatever else
// the body depends on), in the client's preferred coding, from the response cache when it holds it:
// Content-Encoding, Vary: Accept-Encoding, an ETag per coding (If-None-Match answered 304).
void SendEncodedOnce(ServerState& ctx, const httplib::Request& req, httplib::Response& res, const std::string& key,
                     const char* content_type, const std::function<std::string()>& produce);

}  // namespace facespace::api::http
