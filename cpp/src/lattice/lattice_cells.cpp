// The cells a bound covers: the lattice's region, or the cells holding given points, and the
// control points that move a cell (docs/lattice.md, "Certified volume-ratio bounds").
#include "lattice/cell_volume_ratio.hpp"

#include "deformkit/core/validation.hpp"

#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>
#include <tuple>

namespace deformkit {

std::vector<CellSpec> region_cells(const BoxLattice& lattice, bool faces) {
  const LatticeAxes& axes = lattice.axes();
  // Per axis (piece, frozen): the pieces of the domain, and for Blender's linear interpolation
  // the box's faces as the cells beyond them give them (index clamping: the map does not vary
  // along the axis there, so det J jumps, the map being C0): the far face s = 1, which Blender
  // evaluates in cell count - 1, and the near face, where s rounded below 0 falls in cell -1.
  std::vector<std::pair<int, bool>> spans[3];
  for (int a = 0; a < 3; ++a) {
    const bool single = is_blender(axes[a].kind) && axes[a].count == 1;
    for (int i = 0; i < axes[a].pieces(); ++i) spans[a].push_back({i, single});
    if (faces && axes[a].kind == BasisKind::BlenderLinear && !single) {
      spans[a].push_back({-1, true});
      spans[a].push_back({axes[a].count - 1, true});
    }
  }
  std::vector<CellSpec> cells;
  cells.reserve(spans[0].size() * spans[1].size() * spans[2].size());
  for (const auto& x : spans[0])
    for (const auto& y : spans[1])
      for (const auto& z : spans[2]) {
        CellSpec c;
        c.piece = {x.first, y.first, z.first};
        c.frozen = {x.second, y.second, z.second};
        // The near face's cell -1 is reported at its t = 1, on the face (its value is the same all along).
        for (int a = 0; a < 3; ++a)
          if (c.frozen[a]) c.lo[a] = c.hi[a] = c.piece[a] == -1 ? 1.0 : 0.0;
        cells.push_back(c);
      }
  return cells;
}

std::vector<CellSpec> cells_holding(const BoxLattice& lattice, const double* points, std::size_t n,
                                    bool& identity_points) {
  require_finite_rows(points, n, "points");
  const LatticeAxes& axes = lattice.axes();
  const Outside outside = lattice.outside();
  identity_points = false;
  // Key: piece, frozen and (frozen) the fixed t per axis; value: the cell, its t range widened.
  std::map<std::tuple<int, int, int, int, double, double, double>, CellSpec> found;
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3 s = lattice.box().coordinates(Vec3(points[3 * i], points[3 * i + 1], points[3 * i + 2]));
    if (!s.allFinite())
      throw std::invalid_argument("points: row " + std::to_string(i) + " lies so far away that its lattice "
                                  "coordinates overflow");
    CellSpec c;
    bool inside = true;
    AxisSpan span[3];
    for (int a = 0; a < 3; ++a) {
      span[a] = axes[a].locate(s[a], outside);
      inside = inside && span[a].inside;
    }
    if (!inside && outside == Outside::Unchanged) {
      identity_points = true;
      continue;
    }
    if (outside == Outside::Extrapolate && lattice.extrapolation_gain(s) > ControlLattice::kMaxExtrapolationGain)
      throw std::invalid_argument("points: row " + std::to_string(i) + " lies too far outside the lattice for "
                                  "'extrapolate' to evaluate it accurately (docs/lattice.md, \"Far outside\")");
    int flags = 0;
    for (int a = 0; a < 3; ++a) {
      c.piece[a] = span[a].piece;
      const bool single = is_blender(axes[a].kind) && axes[a].count == 1;
      c.frozen[a] = span[a].frozen || single;
      // Blender's frozen cells put every weight on one control point: t does not matter there.
      const double t = c.frozen[a] ? (is_blender(axes[a].kind) ? 0.0 : span[a].t) : 0.0;
      c.lo[a] = c.frozen[a] ? t : std::min(0.0, span[a].t);
      c.hi[a] = c.frozen[a] ? t : std::max(1.0, span[a].t);
      flags |= int(c.frozen[a]) << a;
    }
    const auto key = std::make_tuple(c.piece[0], c.piece[1], c.piece[2], flags, c.frozen[0] ? c.lo[0] : 0.0,
                                     c.frozen[1] ? c.lo[1] : 0.0, c.frozen[2] ? c.lo[2] : 0.0);
    auto [it, fresh] = found.emplace(key, c);
    if (!fresh)
      for (int a = 0; a < 3; ++a)
        if (!c.frozen[a]) {
          it->second.lo[a] = std::min(it->second.lo[a], c.lo[a]);
          it->second.hi[a] = std::max(it->second.hi[a], c.hi[a]);
        }
  }
  std::vector<CellSpec> cells;
  cells.reserve(found.size());
  for (auto& kv : found) cells.push_back(kv.second);
  return cells;
}

std::vector<std::array<int, 3>> cell_control_indices(const BoxLattice& lattice, const std::array<int, 3>& cell) {
  const LatticeAxes& axes = lattice.axes();
  CellSpec spec;
  spec.piece = cell;
  std::vector<int> index[3];
  for (int a = 0; a < 3; ++a) {
    const int lo = is_blender(axes[a].kind) ? -2 : 0;
    const int hi = is_blender(axes[a].kind) ? axes[a].count : axes[a].pieces() - 1;
    if (cell[a] < lo || cell[a] > hi)
      throw std::invalid_argument("cell: index " + std::to_string(cell[a]) + " along axis " + std::to_string(a) +
                                  " is outside " + std::to_string(lo) + ".." + std::to_string(hi));
    if (is_blender(axes[a].kind) && axes[a].count == 1) spec.frozen[a] = true, spec.hi[a] = 0.0;
    if (is_blender(axes[a].kind) && (cell[a] <= -2 || cell[a] >= axes[a].count)) spec.frozen[a] = true, spec.hi[a] = 0.0;
    const AxisForm f = axis_form(axes[a], spec, a);
    for (int k = 0; k < f.width; ++k)
      if (std::find(index[a].begin(), index[a].end(), f.index[k]) == index[a].end()) index[a].push_back(f.index[k]);
    std::sort(index[a].begin(), index[a].end());
  }
  std::vector<std::array<int, 3>> out;
  for (int i : index[0])
    for (int j : index[1])
      for (int k : index[2]) out.push_back({i, j, k});
  return out;
}

}  // namespace deformkit
