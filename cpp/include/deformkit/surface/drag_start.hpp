#pragma once
// Initial guesses for ARAP over a drag (SurfaceDeformer::deform's `initial`). A warm start from
// the previous result leaves the iteration the step's whole change to find, and local/global ARAP
// finds a smooth, mesh-wide change slowly (linear convergence at a rate set by the mesh's lowest
// frequencies). Over a drag that change is nearly the last step's again, so a first-order
// predictor, as continuation methods use, starts the iteration near the new solution.
#include <cstddef>
#include <vector>

namespace deformkit {

// previous + s (previous - earlier) for the last two results (3 * vertices each): s is the
// handles' present step (targets - previous_targets) projected on their last one (previous_targets
// - earlier_targets), clipped to [0, 2]; 0 (previous itself) when they stood still last step or
// now turn back or across.
std::vector<double> extrapolated_start(const double* previous, const double* earlier, std::size_t vertices,
                                       const double* targets, const double* previous_targets,
                                       const double* earlier_targets, std::size_t handles);

}  // namespace deformkit
