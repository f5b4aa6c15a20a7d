// Content negotiation (Accept, Content-Type) and the structured-field headers of a result.
#pragma once

#include <httplib.h>

#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "facespace/engine/status.h"
#include "facespace/formats/io.h"
#include "facespace/offscreen/render.h"

namespace facespace::http {

// The media type of a Content-Type value or of one Accept item, lowercased, without parameters.
std::string MediaType(std::string_view header);

// The media types an Accept header lists, lowercased, most preferred first: by quality (q), then
// in the order given. Types with q=0 ("not acceptable", RFC 9110 12.5.1) are left out; a q that
// is not a number counts as 1.
std::vector<std::string> AcceptedTypes(std::string_view accept);

// The format the request names (`given`), else the one its Accept header prefers (JSON, PNG for
// none); nullopt, with a 406 sent, when Accept names only types we cannot produce.
std::optional<formats::MeshFormat> NegotiateMesh(const httplib::Request& req,
                                                 httplib::Response& res,
                                                 std::optional<formats::MeshFormat> given);
std::optional<picture::ImageFormat> NegotiateImage(const httplib::Request& req,
                                                   httplib::Response& res,
                                                   std::optional<picture::ImageFormat> given);

// True when the body may be read as JSON (Content-Type application/json, or none); otherwise a 415
// was sent.
bool AcceptsJsonBody(const httplib::Request& req, httplib::Response& res);

// Facespace-Warnings: a structured-field list (RFC 9651), e.g.
//   extrapolation;value=1.7, out_of_range;shape="jawOpen";value=1.5
// Each code and shape once (the first), at most 4 KB, then "more;count=N".
std::string WarningsHeader(std::span<const Warning> warnings);

// Facespace-Weight-Sum, and Facespace-Warnings when there are any.
void SetWeightHeaders(httplib::Response& res, double sum, std::span<const Warning> warnings);

}  // namespace facespace::http
