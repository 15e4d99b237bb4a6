#pragma once
// Certified bounds of a box lattice's volume ratio det J, a fold-over certificate and the exact
// deformed volume, from the Bernstein coefficients of det J cell by cell (docs/math/lattice.md,
// "Certified volume-ratio bounds"; Sederberg-Parry 1986 section 5, Johnen-Remacle-Geuzaine 2013).
// det J is that of the map without the per-point blend weights (volume_ratio with no weights set).
#include "deformkit/lattice/bernstein_algebra.hpp"
#include "deformkit/lattice/box_lattice.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace deformkit {

// One cell of a box lattice: per axis a piece (block, span or Blender cell; Blender's outside
// cells -2, -1, count-1 and count included) and the stretch of its local coordinate t that is
// bounded: [lo, hi] ([0, 1] inside the domain, wider where 'extrapolate' holds points beyond it),
// or a single t (a frozen axis: clamped outside the domain, where the map does not vary with it).
struct CellSpec {
  std::array<int, 3> piece{0, 0, 0};
  std::array<bool, 3> frozen{false, false, false};
  std::array<double, 3> lo{0.0, 0.0, 0.0}, hi{1.0, 1.0, 1.0};  // frozen: lo = hi = the fixed t
};

// det J over a cell in Bernstein form, u in [0,1]^3 spanning [lo, hi] (degree 0 along frozen axes),
// and the rounding allowance: each coefficient is within `rounding` of the exact one.
struct CellVolumeRatio {
  TriPoly coefficients;
  double rounding = 0.0;
};

// The cells of the lattice's region: every piece of the domain, [0, 1] per axis; with faces, also
// the box's two faces along Blender linear axes as the cells beyond them give them (pieces -1 and
// count - 1, frozen), where Blender evaluates points on (or rounded just past) a face.
std::vector<CellSpec> region_cells(const BoxLattice& lattice, bool faces = true);
// The cells holding the given points (n x 3), and whether some point lies where the map is the
// identity ('unchanged' outside the domain: det J = 1 there). Throws std::invalid_argument naming
// `points` for a non-finite row or, with 'extrapolate', one too far out to evaluate.
std::vector<CellSpec> cells_holding(const BoxLattice& lattice, const double* points, std::size_t n,
                                    bool& identity_points);

CellVolumeRatio cell_volume_ratio(const BoxLattice& lattice, const CellSpec& cell);

// A point of the lattice: a cell and local coordinates in it (t per axis: [lo, hi] of the cell).
struct CellPoint {
  std::array<int, 3> cell{0, 0, 0};
  std::array<double, 3> local{0.0, 0.0, 0.0};
};

struct VolumeRatioBounds {
  double lower = 1.0, upper = 1.0;
  bool converged = true;          // false: the work cap stopped the refinement
  double minimum = 1.0;           // the least det J value found (at `where`): lower <= minimum
  CellPoint where;                // where `minimum` was found
  bool has_where = false;         // false: no cells, or the least value is the identity's 1
  double scale = 1.0;             // the tolerance is relative to this: max(1, max |det J| found)
  std::size_t cells = 0;          // cells bounded
  std::size_t subdivisions = 0;   // de Casteljau subdivisions made
};

// Work cap of the refinement: at most this many coefficients subdivided over the whole call
// (each subdivision of a cell piece of N coefficients counts N), and at most kMaxLivePieces
// pieces awaiting refinement in one cell.
constexpr double kSubdivisionBudget = double(1 << 24);
constexpr std::size_t kMaxLivePieces = 1 << 14;

// Bounds of det J over `cells` (identity_points: include the value 1); lower within
// tolerance * scale of the true minimum and upper of the true maximum unless the cap is hit.
// Throws std::invalid_argument naming `tolerance` unless it is finite and > 0.
VolumeRatioBounds volume_ratio_bounds(const BoxLattice& lattice, const std::vector<CellSpec>& cells,
                                      bool identity_points, double tolerance);

struct FoldCell {
  CellPoint where;       // a point where det J <= 0 (folded) or where the bound is least
  double lower = 0.0;    // the cell's lower bound when the search stopped
  bool folded = false;   // a value det J <= 0 was found; false: not certified within the work cap
};

struct FoldCertificate {
  bool certified = true;  // det J > 0 proven over every cell
  double lower = 1.0;     // the least lower bound the decision reached
  std::vector<FoldCell> cells;
  std::size_t cells_checked = 0;
};

// Each cell refined until its lower bound is positive or a value <= 0 is found in it.
FoldCertificate fold_certificate(const BoxLattice& lattice, const std::vector<CellSpec>& cells, bool identity_points);

// The integral of det J over the lattice's region: the volume of the deformed region (signed:
// folded parts count negatively), each cell's rest volume times the mean of its coefficients.
double deformed_volume(const BoxLattice& lattice);

// The control points (grid indices) whose movement changes the map on `cell` (region cells).
std::vector<std::array<int, 3>> cell_control_indices(const BoxLattice& lattice, const std::array<int, 3>& cell);

}  // namespace deformkit
