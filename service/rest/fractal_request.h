#pragma once
/// Reads a POST /v1/fractals JSON body into fractal generator parameters.

#include <string>
#include <string_view>

#include "service/config/config.h"
#include "service/core/status.h"
#include "service/mesh/fractal.h"
#include "service/mesh/mesh_io.h"

namespace softgrasp::rest {

struct FractalRequest {
  mesh::FractalParams params;
  bool stats_only = false;  ///< format "json": statistics instead of a file
  mesh::MeshFormat format = mesh::MeshFormat::kObj;
};

/// Body: {"seed", "maps" (N or [min, max]), "points", "sigma", "alpha",
/// "scale": {"opening_mm", "fit_fraction"}, "format"}; every key optional.
/// kInvalidArgument naming the field for wrong types, ranges and unknown keys.
core::Result<FractalRequest> ParseFractalRequest(std::string_view body,
                                                 const config::ServiceConfig& config);

/// File name for Content-Disposition, e.g. "fractal-seed42-alpha0.3.obj".
std::string FractalFileName(const FractalRequest& request);

}  // namespace softgrasp::rest
