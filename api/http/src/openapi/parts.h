// The operations' shared parts (parts.cpp): headers, parameters and answers that several routes'
// operations (operations.cpp) are built from.
#pragma once

#include <string_view>

#include "openapi.h"

namespace facespace::http::openapi {

// The headers every answer of the mesh and image routes carries.
json CommonHeaders();
json MeshResponses();
json RenderResponses();
json IdParam();
json JobParam();
// w[NAME]=VALUE or c[NAME]=VALUE: OpenAPI's deepObject style, which generated clients send; the
// server also reads the shorter w.NAME=VALUE of curl lines.
json MapParam(const char* name, const char* description);
// One query parameter of GET mesh or render, by the name the route reads (http/query_params.h): the
// body's member of that name (the camera's, flat: yaw=20), from the member tables. Three read the
// query their own way: camera (the body's object as JSON), frame (a time in MMD frames, or the
// camera's framing) and gaze (short forms); other objects and arrays are the body's as JSON.
json QueryParam(std::string_view name, bool render);
// The parameters of GET mesh or render: the path's id, the weights and controls, and each name
// of the route's list.
json QueryParams(bool render);
// The speech route's settings as query parameters, read with an audio/wav body (a JSON body takes
// them as members): the speech table's members but text and audio, objects as JSON text.
json SpeechQuery();
// What a job's files are: a variant's mesh or image, a labelled sample's EXR and PNG, a tar shard,
// the manifest's lines, batch.json (routes/batch.cpp, FileType).
json JobFileContent();
json OkJson();
// A 200 whose JSON body is the component `name`.
json JsonOk(const char* name, const char* description = "OK");
json Auth();
// A required JSON request body whose schema is the component `name`.
json JsonBody(const char* name);

}  // namespace facespace::http::openapi
