#include "numerics/grid_stencil_level.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>

namespace deformkit::numerics {

namespace {

constexpr const char* kDirection[6] = {"-x", "+x", "-y", "+y", "-z", "+z"};
// Rounding in the caller's sums: a diagonal may fall short of its couplings' sum by this much
// (relative), and a row counts as having a cut edge when it exceeds them by more.
constexpr double kSumRounding = 1e-12;

[[noreturn]] void refuse(const std::string& what) { throw std::invalid_argument("solve_grid_stencil: " + what); }

std::string cell_name(const std::array<int, 3>& n, std::int64_t cell) {
  const std::int64_t i = cell % n[0], j = (cell / n[0]) % n[1], k = cell / (std::int64_t(n[0]) * n[1]);
  return "cell (" + std::to_string(i) + ", " + std::to_string(j) + ", " + std::to_string(k) + ")";
}

// The cell beside `cell` in direction dir, or -1 outside the grid.
std::int64_t neighbour_cell(const std::array<int, 3>& n, std::int64_t cell, int dir) {
  const int axis = dir / 2, step = dir % 2 ? 1 : -1;
  const std::int64_t stride = axis == 0 ? 1 : axis == 1 ? n[0] : std::int64_t(n[0]) * n[1];
  const std::int64_t coord = (cell / stride) % n[std::size_t(axis)] + step;
  return coord < 0 || coord >= n[std::size_t(axis)] ? -1 : cell + step * stride;
}

void fill_colours(StencilLevel& level) {
  const auto& n = level.cells;
  for (std::size_t u = 0; u < level.size; ++u) {
    const int c = level.cell[u];
    const int parity = (c % n[0] + (c / n[0]) % n[1] + c / (n[0] * n[1])) & 1;
    level.colour[std::size_t(parity)].push_back(int(u));
  }
  level.inverse_diagonal.resize(level.size);
  for (std::size_t u = 0; u < level.size; ++u) level.inverse_diagonal[u] = 1.0 / level.diagonal[u];
}

void check_sizes(const GridStencil& s, std::int64_t cells) {
  for (int a = 0; a < 3; ++a)
    if (s.cells[std::size_t(a)] < 1) refuse("system.cells[" + std::to_string(a) + "] is " + std::to_string(s.cells[std::size_t(a)]) + "; each side needs at least 1 cell");
  if (cells > std::numeric_limits<int>::max()) refuse("system.cells make " + std::to_string(cells) + " cells; at most 2^31 - 1 are accepted");
  if (std::int64_t(s.unknown.size()) != cells)
    refuse("system.unknown has " + std::to_string(s.unknown.size()) + " entries; it needs one per cell, " + std::to_string(cells));
  if (s.coupling.size() != s.diagonal.size())
    refuse("system.coupling has " + std::to_string(s.coupling.size()) + " rows and system.diagonal " + std::to_string(s.diagonal.size()) + "; both need one per unknown");
}

// Each connected group of unknowns needs a cut edge (a diagonal above its couplings' sum), or the
// system is singular: constants solve its homogeneous equations.
void check_groups_anchored(const StencilLevel& level, const std::vector<double>& excess) {
  std::vector<char> seen(level.size, 0);
  std::vector<int> stack;
  for (std::size_t start = 0; start < level.size; ++start) {
    if (seen[start]) continue;
    bool anchored = false;
    std::size_t count = 0;
    seen[start] = 1, stack.push_back(int(start));
    while (!stack.empty()) {
      const std::size_t u = std::size_t(stack.back());
      stack.pop_back(), ++count;
      anchored = anchored || excess[u] > kSumRounding * level.diagonal[u];
      for (int d = 0; d < 6; ++d) {
        const std::size_t v = std::size_t(level.neighbour[u][d]);
        if (v < level.size && level.coupling[u][d] > 0.0 && !seen[v]) seen[v] = 1, stack.push_back(int(v));
      }
    }
    if (!anchored)
      refuse("system is singular: the " + std::to_string(count) + " connected unknowns around " + cell_name(level.cells, level.cell[start]) +
             " have no cut edge (each diagonal equals its couplings' sum); every connected group needs one");
  }
}

}  // namespace

StencilLevel checked_fine_level(const GridStencil& s, std::vector<int>& external) {
  const std::int64_t cells = std::int64_t(s.cells[0] > 0 ? s.cells[0] : 0) * (s.cells[1] > 0 ? s.cells[1] : 0) * (s.cells[2] > 0 ? s.cells[2] : 0);
  check_sizes(s, cells);
  const std::size_t m = s.diagonal.size();
  StencilLevel level;
  level.cells = s.cells;
  std::vector<int> internal(m, -1);
  external.clear();
  for (std::int64_t c = 0; c < cells; ++c) {
    const int e = s.unknown[std::size_t(c)];
    if (e == -1) continue;
    if (e < -1 || std::size_t(e) >= m)
      refuse("system.unknown of " + cell_name(s.cells, c) + " is " + std::to_string(e) + "; it must be -1 or an unknown index below system.diagonal.size() = " + std::to_string(m));
    if (internal[std::size_t(e)] != -1) refuse("system.unknown gives index " + std::to_string(e) + " to two cells; each unknown needs exactly one cell");
    internal[std::size_t(e)] = int(level.cell.size());
    level.cell.push_back(int(c));
    external.push_back(e);
  }
  if (level.cell.size() != m)
    refuse("system.unknown names " + std::to_string(level.cell.size()) + " unknowns but system.diagonal has " + std::to_string(m) + "; every unknown needs a cell");
  level.size = m;
  level.diagonal.resize(m), level.coupling.resize(m), level.neighbour.resize(m);
  std::vector<double> excess(m);
  for (std::size_t u = 0; u < m; ++u) {
    const std::size_t e = std::size_t(external[u]);
    const double d = s.diagonal[e];
    if (!(d > 0.0) || !std::isfinite(d))
      refuse("system.diagonal[" + std::to_string(e) + "] is " + std::to_string(d) + "; a diagonal must be positive and finite");
    double sum = 0.0;
    for (int dir = 0; dir < 6; ++dir) {
      const double w = s.coupling[e][std::size_t(dir)];
      // Built only to refuse: a string per coupling cost 1-2% of a precision-8 bind.
      auto where = [&] { return "system.coupling[" + std::to_string(e) + "][" + std::to_string(dir) + "] (" + kDirection[dir] + " of " + cell_name(s.cells, level.cell[u]) + ")"; };
      if (!(w >= 0.0) || !std::isfinite(w)) refuse(where() + " is " + std::to_string(w) + "; a coupling must be finite and >= 0");
      const std::int64_t nc = neighbour_cell(s.cells, level.cell[u], dir);
      const int ne = nc < 0 ? -1 : s.unknown[std::size_t(nc)];
      level.neighbour[u][std::size_t(dir)] = ne < 0 ? int(m) : internal[std::size_t(ne)];
      if (ne < 0) {
        if (w != 0.0) refuse(where() + " is " + std::to_string(w) + " but that neighbour is not an unknown; it must be 0 (a cut edge's weight goes on the diagonal only)");
      } else {
        const double back = s.coupling[std::size_t(ne)][std::size_t(dir ^ 1)];
        if (std::abs(w - back) > kSumRounding * std::max(w, back))
          refuse(where() + " is " + std::to_string(w) + " but the neighbour's coupling back is " + std::to_string(back) + "; the system must be symmetric");
      }
      level.coupling[u][std::size_t(dir)] = w;
      sum += w;
    }
    if (d < sum * (1.0 - kSumRounding))
      refuse("system.diagonal[" + std::to_string(e) + "] is " + std::to_string(d) + ", below the sum of its couplings " + std::to_string(sum) + "; a diagonal is the sum of its 6 edge weights, cut edges included");
    level.diagonal[u] = d;
    excess[u] = d - sum;
  }
  check_groups_anchored(level, excess);
  fill_colours(level);
  return level;
}

void round_to_single(StencilLevel& a) {
  a.single.diagonal.assign(a.diagonal.begin(), a.diagonal.end());
  a.single.inverse_diagonal.assign(a.inverse_diagonal.begin(), a.inverse_diagonal.end());
  a.single.coupling.resize(a.size);
  for (std::size_t u = 0; u < a.size; ++u)
    for (int d = 0; d < 6; ++d) a.single.coupling[u][std::size_t(d)] = float(a.coupling[u][std::size_t(d)]);
}

StencilLevel aggregated_level(StencilLevel& fine) {
  const auto& n = fine.cells;
  StencilLevel coarse;
  coarse.cells = {(n[0] + 1) / 2, (n[1] + 1) / 2, (n[2] + 1) / 2};
  const auto& cn = coarse.cells;
  auto coarse_cell = [&](int c) {
    const int i = c % n[0], j = (c / n[0]) % n[1], k = c / (n[0] * n[1]);
    return i / 2 + cn[0] * (j / 2 + cn[1] * (k / 2));
  };
  std::vector<int> index(std::size_t(cn[0]) * cn[1] * cn[2], -1);
  for (std::size_t u = 0; u < fine.size; ++u) index[std::size_t(coarse_cell(fine.cell[u]))] = 0;
  for (std::size_t c = 0; c < index.size(); ++c)
    if (index[c] == 0) index[c] = int(coarse.cell.size()), coarse.cell.push_back(int(c));
  const std::size_t m = coarse.cell.size();
  coarse.size = m;
  fine.parent.resize(fine.size);
  fine.child_start.assign(m + 1, 0);
  for (std::size_t u = 0; u < fine.size; ++u) {
    fine.parent[u] = index[std::size_t(coarse_cell(fine.cell[u]))];
    ++fine.child_start[std::size_t(fine.parent[u]) + 1];
  }
  for (std::size_t g = 0; g < m; ++g) fine.child_start[g + 1] += fine.child_start[g];
  fine.child.resize(fine.size);
  std::vector<int> next(fine.child_start.begin(), fine.child_start.end() - 1);
  // Colour 0 first: after the pre-smoothing's last (colour 1) sweep only colour-0 rows have a
  // residual, so the restriction reads those alone.
  for (int colour = 0; colour < 2; ++colour) {
    for (const int u : fine.colour[std::size_t(colour)]) fine.child[std::size_t(next[std::size_t(fine.parent[std::size_t(u)])]++)] = u;
    if (colour == 0) fine.colour0_end = next;
  }
  // (P^T A P)_GG = sum of the children's diagonals minus their couplings inside G (each pair seen
  // from both sides); (P^T A P)_GH = minus the sum of the couplings across the face G | H.
  coarse.diagonal.assign(m, 0.0);
  coarse.coupling.assign(m, {0, 0, 0, 0, 0, 0});
  coarse.neighbour.resize(m);
  for (std::size_t g = 0; g < m; ++g) {
    double d = 0.0;
    for (int k = fine.child_start[g]; k < fine.child_start[g + 1]; ++k) {
      const std::size_t u = std::size_t(fine.child[std::size_t(k)]);
      d += fine.diagonal[u];
      for (int dir = 0; dir < 6; ++dir) {
        const std::size_t v = std::size_t(fine.neighbour[u][std::size_t(dir)]);
        if (v >= fine.size) continue;
        if (std::size_t(fine.parent[v]) == g)
          d -= fine.coupling[u][std::size_t(dir)];
        else
          coarse.coupling[g][std::size_t(dir)] += fine.coupling[u][std::size_t(dir)];
      }
    }
    coarse.diagonal[g] = d;
    for (int dir = 0; dir < 6; ++dir) {
      const std::int64_t nc = neighbour_cell(cn, coarse.cell[g], dir);
      const int h = nc < 0 ? -1 : index[std::size_t(nc)];
      coarse.neighbour[g][std::size_t(dir)] = h < 0 ? int(m) : h;
    }
  }
  fill_colours(coarse);
  return coarse;
}

}  // namespace deformkit::numerics
