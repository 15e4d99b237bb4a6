// Bounds of det J from its Bernstein coefficients, tightened by de Casteljau subdivision
// (docs/math/lattice.md, "Certified volume-ratio bounds"; Johnen, Remacle, Geuzaine 2013, sec. 3):
// the coefficients of a piece enclose its values (convex hull), its corner coefficients are
// values, and halving a piece brings its coefficients toward its values.
#include "deformkit/lattice/jacobian_bounds.hpp"

#include "core/parallel.hpp"
#include "lattice/cell_volume_ratio.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <mutex>
#include <queue>
#include <stdexcept>
#include <string>

namespace deformkit {

namespace {

constexpr double kEps = std::numeric_limits<double>::epsilon();
constexpr int kMaxDepth = 40;  // a piece 2^-40 of its cell wide: rounding, not the polynomial, is left

// A box [lo, hi] of a cell's unit parameter cube and det J over it in Bernstein form.
struct Piece {
  TriPoly p;
  std::array<double, 3> lo{0, 0, 0}, hi{1, 1, 1};
  int depth = 0;
  double lower = 0, upper = 0;           // coefficient bounds widened by the rounding allowance
  double delta = 0;                       // that allowance
  double corner_min = 0, corner_max = 0;  // values: the corner coefficients
  std::array<double, 3> at_min{}, at_max{}, at_lowest{};  // unit-cube points of those, and of the least coefficient
};

bool can_split(const Piece& q) { return q.depth < kMaxDepth && (q.p.degree[0] | q.p.degree[1] | q.p.degree[2]) != 0; }
// Halving brings a piece's least (greatest) coefficient toward its least (greatest) corner value;
// once they are within twice the rounding allowance it cannot bring the bound any closer.
bool lower_can_tighten(const Piece& q) { return can_split(q) && q.corner_min - q.lower > 2.0 * q.delta; }
bool upper_can_tighten(const Piece& q) { return can_split(q) && q.upper - q.corner_max > 2.0 * q.delta; }

// The cell's bound on rounding plus what halving adds: one rounding per de Casteljau level.
Piece make_piece(TriPoly&& p, const std::array<double, 3>& lo, const std::array<double, 3>& hi, int depth,
                 double rounding, double max_abs) {
  Piece q;
  q.p = std::move(p);
  q.lo = lo, q.hi = hi, q.depth = depth;
  const auto& d = q.p.degree;
  const double delta = rounding + depth * 3.0 * (d[0] + d[1] + d[2] + 1) * kEps * max_abs;
  std::size_t lowest = 0, highest = 0;
  for (std::size_t e = 1; e < q.p.c.size(); ++e) {
    if (q.p.c[e] < q.p.c[lowest]) lowest = e;
    if (q.p.c[e] > q.p.c[highest]) highest = e;
  }
  q.delta = delta;
  q.lower = q.p.c[lowest] - delta;
  q.upper = q.p.c[highest] + delta;
  auto point = [&](int i, int j, int k) {
    const int idx[3] = {i, j, k};
    std::array<double, 3> u;
    for (int a = 0; a < 3; ++a) u[a] = lo[a] + (d[a] ? double(idx[a]) / d[a] : 0.5) * (hi[a] - lo[a]);
    return u;
  };
  const std::size_t n2 = d[2] + 1, n12 = std::size_t(d[1] + 1) * n2;
  q.at_lowest = point(int(lowest / n12), int(lowest / n2 % (d[1] + 1)), int(lowest % n2));
  q.corner_min = std::numeric_limits<double>::infinity();
  q.corner_max = -q.corner_min;
  for (int i : {0, d[0]})
    for (int j : {0, d[1]})
      for (int k : {0, d[2]}) {
        const double v = q.p.at(i, j, k);
        if (v < q.corner_min) q.corner_min = v, q.at_min = point(i, j, k);
        if (v > q.corner_max) q.corner_max = v, q.at_max = point(i, j, k);
      }
  return q;
}

// The halves of q along every axis it varies on: up to eight pieces.
std::vector<Piece> subdivide(const Piece& q, double rounding, double max_abs) {
  std::vector<Piece> parts;
  struct Box {
    TriPoly p;
    std::array<double, 3> lo, hi;
  };
  std::vector<Box> boxes{{q.p, q.lo, q.hi}};
  for (int a = 0; a < 3; ++a) {
    if (q.p.degree[a] == 0) continue;
    std::vector<Box> next;
    for (Box& b : boxes) {
      Box low{{}, b.lo, b.hi}, high{{}, b.lo, b.hi};
      split_half(b.p, a, low.p, high.p);
      const double mid = 0.5 * (b.lo[a] + b.hi[a]);
      low.hi[a] = mid, high.lo[a] = mid;
      next.push_back(std::move(low));
      next.push_back(std::move(high));
    }
    boxes.swap(next);
  }
  for (Box& b : boxes) parts.push_back(make_piece(std::move(b.p), b.lo, b.hi, q.depth + 1, rounding, max_abs));
  return parts;
}

CellPoint cell_point(const CellSpec& cell, const std::array<double, 3>& u) {
  CellPoint p;
  p.cell = cell.piece;
  for (int a = 0; a < 3; ++a) p.local[a] = cell.lo[a] + u[a] * (cell.hi[a] - cell.lo[a]);
  return p;
}

// The least (or greatest) value found so far and where, shared by the threads.
class Extreme {
 public:
  explicit Extreme(bool least) : least_(least), value_(least ? kInf : -kInf) {}
  double value() const { return value_.load(std::memory_order_relaxed); }
  void offer(double v, const CellSpec& cell, const std::array<double, 3>& u) {
    if (!(least_ ? v < value() : v > value())) return;
    std::lock_guard<std::mutex> lock(mutex_);
    if (!(least_ ? v < value_.load() : v > value_.load())) return;
    value_ = v;
    where_ = cell_point(cell, u);
  }
  CellPoint where() const { return where_; }

 private:
  static constexpr double kInf = std::numeric_limits<double>::infinity();
  bool least_;
  std::atomic<double> value_;
  std::mutex mutex_;
  CellPoint where_;
};

// Cells [0, count) run by fn(cell) on the pool, handed out a few at a time.
template <class Fn>
void for_each_cell(std::size_t count, std::size_t work_per_cell, Fn&& fn) {
  const bool parallel = count >= 2 && count * work_per_cell >= 20000;
  const int threads = parallel ? parallel_threads() : 1;
  std::atomic<std::size_t> next{0};
  constexpr std::size_t kChunk = 8;
  parallel_tasks(threads, [&](int) {
    for (std::size_t begin; (begin = next.fetch_add(kChunk)) < count;)
      for (std::size_t c = begin; c < std::min(count, begin + kChunk); ++c) fn(c);
  });
}

// The coefficients of a cell's det J, (3 n_a) per axis of degree n_a (at most: a cell may have
// frozen axes): what a cell's work and memory scale with.
std::size_t coefficients_per_cell(const BoxLattice& lattice) {
  std::size_t size = 1;
  for (const AxisBasis& a : lattice.axes()) {
    const int degree = a.kind == BasisKind::Bernstein ? a.count - 1
                       : a.kind == BasisKind::BlenderLinear ? 1
                       : is_blender(a.kind) && a.count == 1 ? 0
                                                            : 3;
    size *= std::size_t(degree > 0 ? 3 * degree : 1);
  }
  return size;
}

struct CellRoot {
  double lower = 0, upper = 0;
};

// The budget of coefficients subdivided, shared by the threads: false once spent.
struct Budget {
  std::atomic<double> left{kSubdivisionBudget};
  std::atomic<std::size_t> subdivisions{0};
  bool take(std::size_t coefficients) {
    subdivisions.fetch_add(1, std::memory_order_relaxed);
    double have = left.load();
    while (have > 0 && !left.compare_exchange_weak(have, have - double(coefficients))) {}
    return have > 0;
  }
};

struct ByLower {
  bool operator()(const Piece& a, const Piece& b) const { return a.lower > b.lower; }
};
struct ByUpper {
  bool operator()(const Piece& a, const Piece& b) const { return a.upper < b.upper; }
};

double max_abs_of(const TriPoly& p) {
  double m = 0.0;
  for (double c : p.c) m = std::max(m, std::abs(c));
  return m;
}

}  // namespace

VolumeRatioBounds volume_ratio_bounds(const BoxLattice& lattice, const std::vector<CellSpec>& cells,
                                      bool identity_points, double tolerance) {
  if (!std::isfinite(tolerance) || !(tolerance > 0.0))
    throw std::invalid_argument("tolerance: must be finite and > 0, got " + std::to_string(tolerance));
  const LatticeView view(lattice);
  VolumeRatioBounds out;
  out.cells = cells.size();
  Extreme least(true), greatest(false);
  std::vector<CellRoot> roots(cells.size());
  // Keep the first pass's coefficients when they are few enough; otherwise recompute them.
  const std::size_t per_cell = coefficients_per_cell(lattice);
  const bool keep = cells.size() * per_cell <= (std::size_t(1) << 22);
  std::vector<CellVolumeRatio> kept(keep ? cells.size() : 0);
  for_each_cell(cells.size(), per_cell, [&](std::size_t c) {
    CellVolumeRatio cv = cell_volume_ratio(view, cells[c]);
    const double rounding = cv.rounding;
    const Piece q = make_piece(keep ? TriPoly(cv.coefficients) : std::move(cv.coefficients), {0, 0, 0}, {1, 1, 1}, 0,
                               rounding, 0.0);
    roots[c] = {q.lower, q.upper};
    least.offer(q.corner_min, cells[c], q.at_min);
    greatest.offer(q.corner_max, cells[c], q.at_max);
    if (keep) kept[c] = std::move(cv);
  });
  out.scale = std::max({1.0, std::abs(least.value()), std::abs(greatest.value())});
  if (cells.empty()) out.scale = 1.0;
  const double gap = tolerance * out.scale;
  Budget budget;
  std::atomic<bool> capped{false};
  std::vector<std::size_t> refine;
  for (std::size_t c = 0; c < cells.size(); ++c)
    if (roots[c].lower + gap < least.value() || roots[c].upper - gap > greatest.value()) refine.push_back(c);
  for_each_cell(refine.size(), per_cell * 64, [&](std::size_t r) {
    const std::size_t c = refine[r];
    CellVolumeRatio cv = keep ? std::move(kept[c]) : cell_volume_ratio(view, cells[c]);
    const double max_abs = max_abs_of(cv.coefficients);
    std::vector<Piece> done;
    std::priority_queue<Piece, std::vector<Piece>, ByLower> low;
    low.push(make_piece(std::move(cv.coefficients), {0, 0, 0}, {1, 1, 1}, 0, cv.rounding, max_abs));
    // Lower bound: the piece with the least bound is halved until it is within the gap of the
    // least value found anywhere.
    while (!low.empty() && low.top().lower + gap < least.value()) {
      if (!lower_can_tighten(low.top())) {
        done.push_back(low.top());
        low.pop();
        capped = true;
        continue;
      }
      if (low.size() > kMaxLivePieces || !budget.take(low.top().p.size())) {
        capped = true;
        break;
      }
      const Piece q = low.top();
      low.pop();
      for (Piece& part : subdivide(q, cv.rounding, max_abs)) {
        least.offer(part.corner_min, cells[c], part.at_min);
        greatest.offer(part.corner_max, cells[c], part.at_max);
        low.push(std::move(part));
      }
    }
    std::priority_queue<Piece, std::vector<Piece>, ByUpper> high;
    for (; !low.empty(); low.pop()) high.push(low.top());
    for (Piece& q : done) high.push(std::move(q));  // settled for the lower bound, not the upper
    done.clear();
    while (!high.empty() && high.top().upper - gap > greatest.value()) {
      if (!upper_can_tighten(high.top())) {
        done.push_back(high.top());
        high.pop();
        capped = true;
        continue;
      }
      if (high.size() > kMaxLivePieces || !budget.take(high.top().p.size())) {
        capped = true;
        break;
      }
      const Piece q = high.top();
      high.pop();
      for (Piece& part : subdivide(q, cv.rounding, max_abs)) {
        least.offer(part.corner_min, cells[c], part.at_min);
        greatest.offer(part.corner_max, cells[c], part.at_max);
        high.push(std::move(part));
      }
    }
    double cell_lower = std::numeric_limits<double>::infinity();
    double cell_upper = -std::numeric_limits<double>::infinity();
    for (const Piece& q : done) cell_lower = std::min(cell_lower, q.lower), cell_upper = std::max(cell_upper, q.upper);
    for (; !high.empty(); high.pop())
      cell_lower = std::min(cell_lower, high.top().lower), cell_upper = std::max(cell_upper, high.top().upper);
    roots[c] = {cell_lower, cell_upper};
  });
  out.lower = std::numeric_limits<double>::infinity();
  out.upper = -out.lower;
  for (const CellRoot& r : roots) out.lower = std::min(out.lower, r.lower), out.upper = std::max(out.upper, r.upper);
  out.minimum = least.value();
  out.where = least.where();
  out.has_where = !cells.empty();
  if (identity_points) {
    out.lower = std::min(out.lower, 1.0), out.upper = std::max(out.upper, 1.0);
    if (!(out.minimum <= 1.0)) out.minimum = 1.0, out.has_where = false;
  }
  out.converged = !capped;
  out.subdivisions = budget.subdivisions.load();
  return out;
}

FoldCertificate fold_certificate(const BoxLattice& lattice, const std::vector<CellSpec>& cells, bool identity_points) {
  const LatticeView view(lattice);
  FoldCertificate out;
  out.cells_checked = cells.size();
  out.lower = identity_points ? 1.0 : std::numeric_limits<double>::infinity();
  std::vector<double> lower(cells.size());
  std::vector<FoldCell> found(cells.size());
  std::vector<char> flagged(cells.size(), 0);
  Budget budget;
  const std::size_t per_cell = coefficients_per_cell(lattice);
  for_each_cell(cells.size(), per_cell, [&](std::size_t c) {
    CellVolumeRatio cv = cell_volume_ratio(view, cells[c]);
    const double max_abs = max_abs_of(cv.coefficients);
    Piece root = make_piece(std::move(cv.coefficients), {0, 0, 0}, {1, 1, 1}, 0, cv.rounding, max_abs);
    if (root.lower > 0.0) {  // most cells: certified by their coefficients alone
      lower[c] = root.lower;
      return;
    }
    std::priority_queue<Piece, std::vector<Piece>, ByLower> heap;
    heap.push(std::move(root));
    FoldCell fold;
    // A piece with a value <= 0 decides the cell; so does a least bound > 0.
    auto folds = [&](const Piece& q) {
      if (q.corner_min > 0.0) return false;
      fold.folded = true;
      fold.where = cell_point(cells[c], q.at_min);
      return true;
    };
    bool decided = folds(heap.top());
    while (!decided && heap.top().lower <= 0.0) {
      const Piece& top = heap.top();
      if (!lower_can_tighten(top) || heap.size() > kMaxLivePieces || !budget.take(top.p.size())) {
        fold.where = cell_point(cells[c], top.at_lowest);
        break;
      }
      const Piece q = heap.top();
      heap.pop();
      for (Piece& part : subdivide(q, cv.rounding, max_abs)) {
        decided = decided || folds(part);
        heap.push(std::move(part));
      }
    }
    lower[c] = heap.top().lower;
    fold.lower = lower[c];
    if (fold.folded || lower[c] <= 0.0) {
      flagged[c] = 1;
      found[c] = fold;
    }
  });
  for (std::size_t c = 0; c < cells.size(); ++c) {
    out.lower = std::min(out.lower, lower[c]);
    if (flagged[c]) out.cells.push_back(found[c]);
  }
  if (cells.empty() && !identity_points) out.lower = 1.0;
  out.certified = out.cells.empty() && out.lower > 0.0;
  return out;
}

double deformed_volume(const BoxLattice& lattice) {
  const LatticeView view(lattice);
  const std::vector<CellSpec> cells = region_cells(lattice, false);  // faces have no volume
  std::vector<double> volume(cells.size());
  const std::size_t per_cell = coefficients_per_cell(lattice);
  for_each_cell(cells.size(), per_cell, [&](std::size_t c) {
    const TriPoly p = cell_volume_ratio(view, cells[c]).coefficients;
    double sum = 0.0;
    for (double x : p.c) sum += x;
    volume[c] = cell_rest_volume(lattice, cells[c]) * (sum / double(p.c.size()));
  });
  double total = 0.0;
  for (double v : volume) total += v;
  return total;
}

}  // namespace deformkit
