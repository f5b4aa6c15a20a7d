// The npm packages the page runs but the binary does not embed (too large to: MediaPipe's face
// tracker, its wasm and its model, 17 MB), served from the folder `.ci/dev` installs them in
// (build/page/node_modules; FACESPACE_PAGE_MODULES at build time): GET /vendor/face_mesh/NAME, NAME
// a file of the package (letters, _ and one extension of js, wasm, data, binarypb), read once and
// kept. Without the folder the routes answer 404 and the page's camera says it has no tracker.
#pragma once

#include <httplib.h>

namespace facespace::cli {

void ServeVendor(httplib::Server& server);

}  // namespace facespace::cli
