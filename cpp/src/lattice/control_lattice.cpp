#include "deformkit/lattice/control_lattice.hpp"

#include "lattice/cell_runs.hpp"
#include "lattice/lattice_kernel.hpp"
#include "lattice/placement_kernel.hpp"
#include "core/parallel.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <unordered_map>

namespace deformkit {

namespace {

struct AxisWeights {
  double w[kMaxAxisWidth], dw[kMaxAxisWidth];
  int index[kMaxAxisWidth];
  int width;
};

// The sorted copies of the points of the binding's dtype.
template <class T>
const Buffer<T>& sorted_points(const LatticeBinding& b) {
  if constexpr (std::is_same<T, float>::value) return b.sorted_f;
  else return b.sorted_d;
}

Buffer<float>& sorted_points_of(LatticeBinding& b, float*) { return b.sorted_f; }
Buffer<double>& sorted_points_of(LatticeBinding& b, double*) { return b.sorted_d; }

// A cell key's index into the binding's distinct cells: a table while the keys are few enough.
class CellIds {
 public:
  explicit CellIds(std::uint64_t still) : dense_(still + 1 <= (std::uint64_t(1) << 22) ? still + 1 : 0, -1) {}
  std::int32_t& operator[](std::uint64_t k) { return dense_.empty() ? sparse_.try_emplace(k, -1).first->second : dense_[k]; }

 private:
  std::vector<std::int32_t> dense_;
  std::unordered_map<std::uint64_t, std::int32_t> sparse_;
};

// Run r of the binding starts at `begin` in cell `key`; the cell joins the distinct cells when
// first seen.
void add_run(LatticeBinding& b, CellIds& ids, std::uint32_t begin, std::uint64_t key, bool moves,
             const std::array<std::int32_t, 3>& cell) {
  b.run_begin.push_back(begin);
  std::int32_t& id = ids[key];
  if (id < 0) {
    id = static_cast<std::int32_t>(b.cells.size());
    b.cells.push_back(cell);
    b.cell_moves.push_back(moves);
  }
  b.run_cell.push_back(id);
}

std::string grid_index(int flat, const std::array<int, 3>& res) {
  const int k = flat % res[2], j = (flat / res[2]) % res[1], i = flat / (res[1] * res[2]);
  return "[" + std::to_string(i) + ", " + std::to_string(j) + ", " + std::to_string(k) + "]";
}

}  // namespace

ControlLattice::ControlLattice(const LatticeAxes& axes, std::vector<double> rest, Outside outside, double strength)
    : axes_(axes), rest_(std::move(rest)), outside_(outside), strength_(strength) {
  if (!std::isfinite(strength)) throw std::invalid_argument("strength: is not finite");
  control_ = rest_;
  offset_.assign(rest_.size(), 0.0);
  handle_count_ = static_cast<int>(control_count());
  handle_of_.resize(handle_count_);
  for (int i = 0; i < handle_count_; ++i) handle_of_[i] = i;
  if (outside_ == Outside::Extrapolate) find_safe_ranges();
}

// Per axis, the coordinates within which sum |w_axis| stays at most 99: a point inside all three
// ranges has a gain below 99^3 < kMaxExtrapolationGain and needs no weights evaluated. sum |w| is
// 1 + 2 (the negative weights' magnitudes), which grow monotonically away from the domain for
// Bernstein and B-spline end pieces, so bisection finds each end.
void ControlLattice::find_safe_ranges() {
  constexpr double kSafeAxisGain = 99.0;
  for (int a = 0; a < 3; ++a) {
    const AxisBasis& axis = axes_[a];
    auto gain = [&](double s) {
      double w[kMaxAxisWidth];
      int index[kMaxAxisWidth];
      axis.evaluate(axis.locate(s, outside_), w, nullptr, index);
      double sum = 0.0;
      for (int k = 0; k < axis.width(); ++k) sum += std::abs(w[k]);
      return sum;
    };
    for (int side = 0; side < 2; ++side) {
      const double end = side ? axis.domain_hi() : axis.domain_lo(), away = side ? 1.0 : -1.0;
      double in = 0.0, out = 1.0;  // distances from the end: gain(in) <= kSafeAxisGain < gain(out)
      while (gain(end + away * out) <= kSafeAxisGain) in = out, out *= 2.0;
      for (int i = 0; i < 64; ++i) {
        const double mid = 0.5 * (in + out);
        (gain(end + away * mid) <= kSafeAxisGain ? in : out) = mid;
      }
      (side ? safe_hi_ : safe_lo_)[a] = end + away * in;
    }
  }
}

void ControlLattice::merge_coincident_control_points(double tolerance) {
  // Hash points into cells of the tolerance's size; a partner can only be in a neighbouring cell.
  const int n = static_cast<int>(control_count());
  auto cell = [&](int a, int d) { return static_cast<std::int64_t>(std::floor(rest_[3 * a + d] / tolerance)); };
  auto hash = [](std::int64_t x, std::int64_t y, std::int64_t z) {
    return std::uint64_t(x) * 73856093ull ^ std::uint64_t(y) * 19349663ull ^ std::uint64_t(z) * 83492791ull;
  };
  std::unordered_multimap<std::uint64_t, int> seen;  // cell hash -> earlier representative
  std::vector<int> representative(n);
  for (int a = 0; a < n; ++a) {
    representative[a] = a;
    const std::int64_t cx = cell(a, 0), cy = cell(a, 1), cz = cell(a, 2);
    for (std::int64_t dx = -1; dx <= 1 && representative[a] == a; ++dx)
      for (std::int64_t dy = -1; dy <= 1 && representative[a] == a; ++dy)
        for (std::int64_t dz = -1; dz <= 1 && representative[a] == a; ++dz) {
          const auto range = seen.equal_range(hash(cx + dx, cy + dy, cz + dz));
          for (auto it = range.first; it != range.second; ++it) {
            const int r = it->second;
            const double d = std::hypot(rest_[3 * a] - rest_[3 * r], rest_[3 * a + 1] - rest_[3 * r + 1],
                                        rest_[3 * a + 2] - rest_[3 * r + 2]);
            if (d <= tolerance) {
              representative[a] = r;
              break;
            }
          }
        }
    if (representative[a] == a) seen.emplace(hash(cx, cy, cz), a);
  }
  std::vector<int> handle_id(n, -1);
  handle_count_ = 0;
  for (int a = 0; a < n; ++a)
    if (representative[a] == a) handle_id[a] = handle_count_++;
  for (int a = 0; a < n; ++a) handle_of_[a] = handle_id[representative[a]];
}

void ControlLattice::set_control_points(std::vector<double> grid) {
  const auto res = resolution();
  if (grid.size() != rest_.size())
    throw std::invalid_argument("control_points: expected " + std::to_string(control_count()) + " points (" +
                                std::to_string(res[0]) + " x " + std::to_string(res[1]) + " x " +
                                std::to_string(res[2]) + "), got " + std::to_string(grid.size() / 3));
  for (std::size_t i = 0; i < grid.size(); ++i)
    if (!std::isfinite(grid[i]))
      throw std::invalid_argument("control_points: point " + grid_index(int(i / 3), res) + " is not finite");
  // Merged points are one handle: moving them apart would tear the lattice (a cylinder's seam).
  std::vector<int> first(handle_count_, -1);
  for (int a = 0; a < int(control_count()); ++a) {
    int& f = first[handle_of_[a]];
    if (f < 0) {
      f = a;
      continue;
    }
    const double d = std::hypot(grid[3 * a] - grid[3 * f], grid[3 * a + 1] - grid[3 * f + 1],
                                grid[3 * a + 2] - grid[3 * f + 2]);
    const double scale = 1.0 + std::abs(grid[3 * f]) + std::abs(grid[3 * f + 1]) + std::abs(grid[3 * f + 2]);
    if (d > 1e-9 * scale)
      throw std::invalid_argument("control_points: points " + grid_index(f, res) + " and " + grid_index(a, res) +
                                  " coincide at rest and are one merged handle; move them together");
  }
  control_ = std::move(grid);
  at_rest_ = true;
  for (std::size_t i = 0; i < control_.size(); ++i) {
    offset_[i] = control_[i] - rest_[i];
    at_rest_ = at_rest_ && offset_[i] == 0.0;
  }
}

std::uint64_t ControlLattice::layout() const {
  // FNV-1a over the bases and the rest grid: a binding depends on both.
  std::uint64_t h = 1469598103934665603ull;
  auto mix = [&h](const void* p, std::size_t bytes) {
    const auto* c = static_cast<const unsigned char*>(p);
    for (std::size_t i = 0; i < bytes; ++i) h = (h ^ c[i]) * 1099511628211ull;
  };
  for (const auto& a : axes_) {
    mix(&a.kind, sizeof a.kind);
    mix(&a.count, sizeof a.count);
  }
  mix(&outside_, sizeof outside_);
  mix(&layout_salt_, sizeof layout_salt_);
  mix(rest_.data(), rest_.size() * sizeof(double));
  return h;
}

Vec3 ControlLattice::contract(const std::vector<double>& grid, const Vec3& p, Mat3* derivative) const {
  AxisWeights ax[3];
  for (int a = 0; a < 3; ++a) {
    axes_[a].evaluate(axes_[a].locate(p[a], outside_), ax[a].w, derivative ? ax[a].dw : nullptr, ax[a].index);
    ax[a].width = axes_[a].width();
  }
  const int nv = axes_[1].count, nw = axes_[2].count;
  const double* g = grid.data();
  double acc[3] = {0, 0, 0};
  if (!derivative) {
    for (int i = 0; i < ax[0].width; ++i)
      for (int j = 0; j < ax[1].width; ++j) {
        const double wij = ax[0].w[i] * ax[1].w[j];
        const double* row = g + 3 * std::size_t(ax[0].index[i] * nv + ax[1].index[j]) * nw;
        double r[3] = {0, 0, 0};
        for (int k = 0; k < ax[2].width; ++k) {
          const double* c = row + 3 * ax[2].index[k];
          const double wk = ax[2].w[k];
          r[0] += wk * c[0], r[1] += wk * c[1], r[2] += wk * c[2];
        }
        acc[0] += wij * r[0], acc[1] += wij * r[1], acc[2] += wij * r[2];
      }
    return Vec3(acc[0], acc[1], acc[2]);
  }
  Mat3 d = Mat3::Zero();
  for (int i = 0; i < ax[0].width; ++i)
    for (int j = 0; j < ax[1].width; ++j) {
      const double* row = g + 3 * std::size_t(ax[0].index[i] * nv + ax[1].index[j]) * nw;
      for (int k = 0; k < ax[2].width; ++k) {
        const Vec3 c(row[3 * ax[2].index[k]], row[3 * ax[2].index[k] + 1], row[3 * ax[2].index[k] + 2]);
        const double w = ax[0].w[i] * ax[1].w[j] * ax[2].w[k];
        acc[0] += w * c[0], acc[1] += w * c[1], acc[2] += w * c[2];
        d.col(0) += ax[0].dw[i] * ax[1].w[j] * ax[2].w[k] * c;
        d.col(1) += ax[0].w[i] * ax[1].dw[j] * ax[2].w[k] * c;
        d.col(2) += ax[0].w[i] * ax[1].w[j] * ax[2].dw[k] * c;
      }
    }
  *derivative = d;
  return Vec3(acc[0], acc[1], acc[2]);
}

Vec3 ControlLattice::displacement_at(const Vec3& parameters, Mat3* derivative) const {
  return contract(offset_, parameters, derivative);
}

Vec3 ControlLattice::rest_map(const Vec3& parameters, Mat3* derivative) const {
  return contract(rest_, parameters, derivative);
}

namespace {

// The control points a piece touches in the kernel's view of an axis.
void kernel_indices(const AxisBasis& a, int piece, int* index) {
  double w[kMaxAxisWidth];
  int all[kMaxAxisWidth];
  AxisSpan span;
  span.piece = piece;
  a.evaluate(span, w, nullptr, all);
  // Linear uses the middle two of Blender's four indices; a single-point axis only the second.
  const int first = a.kind == BasisKind::BlenderLinear || a.count == 1 ? (is_blender(a.kind) ? 1 : 0) : 0;
  for (int k = 0; k < kernel_axis(a).width; ++k) index[k] = all[first + k];
}

}  // namespace

template <class T>
LatticeBinding ControlLattice::bind_points(const T* in, std::size_t n) const {
  require_finite_rows(in, n, "points");
  if (n >= (std::size_t(1) << 32)) throw std::invalid_argument("points: more than 2^32 - 1 rows");
  LatticeBinding b;
  b.point_count = n;
  b.resolution = resolution();
  b.layout = layout();
  b.single_precision = std::is_same<T, float>::value;
  b.parameters.resize(3 * n);
  b.status.resize(n);
  const std::uint64_t still = still_key();
  OverflowRows overflow;
  // Rows [begin, end) placed; a row whose coordinates overflow is noted and left unplaced.
  auto place_block = [&](std::size_t begin, std::size_t end, std::uint64_t* key, double* local) {
    if (place_rows(in + 3 * begin, end - begin, &b.parameters[3 * begin], &b.status[begin], key, local, nullptr))
      return;
    for (std::size_t i = begin; i < end; ++i) {
      double* p = &b.parameters[3 * i];
      if (std::isfinite(p[0]) && std::isfinite(p[1]) && std::isfinite(p[2])) continue;
      overflow.note(i);
      b.status[i] = static_cast<std::uint8_t>(PointStatus::NotPlaced);
      p[0] = p[1] = p[2] = 0.0;
      key[i - begin] = still;
    }
  };
  if (still + 1 > kCountingSortKeys) {
    Buffer<std::uint64_t> key(n);
    parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
      std::vector<double> local(3 * (end - begin));
      place_block(begin, end, &key[begin], local.data());
    });
    if (overflow.any()) refuse_row(in, overflow.first());
    sort_by_cell(b, in, key.data());
    return b;
  }
  // Placed, sorted and copied chunk by chunk in one pass (a counting sort, linear and stable,
  // inside chunks that fit the L2 cache with everything they write), each chunk's runs noted
  // under its number so that they join in order afterwards.
  constexpr std::size_t kChunk = 32768;
  b.order.resize(n);
  Buffer<T>& sorted = sorted_points_of(b, static_cast<T*>(nullptr));
  sorted.resize(6 * n);
  std::vector<std::vector<std::pair<std::uint32_t, std::uint64_t>>> chunk_runs((n + kChunk - 1) / kChunk);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    ChunkByCell chunk(still + 1, kChunk);
    std::vector<double> local(3 * kChunk);
    for (std::size_t c = (begin + kChunk - 1) / kChunk * kChunk; c < end; c += kChunk) {
      const std::size_t stop = std::min(n, c + kChunk);
      place_block(c, stop, chunk.key.data(), local.data());
      chunk.sort(c, stop - c, [&](std::size_t i, std::size_t slot) {
        const std::uint64_t k = chunk.key[i];
        const std::size_t to = c + slot;
        b.order[to] = static_cast<std::uint32_t>(c + i);
        for (int a = 0; a < 3; ++a) {
          sorted[a * n + to] = k == still ? T(0) : static_cast<T>(local[3 * i + a]);
          sorted[(3 + a) * n + to] = in[3 * (c + i) + a];
        }
      });
      auto& runs = chunk_runs[c / kChunk];
      chunk.runs(stop - c, [&](std::uint64_t k, std::size_t lo, std::size_t) {
        runs.emplace_back(static_cast<std::uint32_t>(c + lo), k);
      });
    }
  });
  if (overflow.any()) refuse_row(in, overflow.first());
  CellIds ids(still);
  for (const auto& runs : chunk_runs)
    for (const auto& [begin, k] : runs) add_run(b, ids, begin, k, k != still, cell_of_key(k));
  b.run_begin.push_back(static_cast<std::uint32_t>(n));
  return b;
}

void ControlLattice::set_affine_placement(const Mat3& to_parameters, const Vec3& origin) {
  affine_ = true;
  to_parameters_ = to_parameters;
  origin_ = origin;
}

double ControlLattice::extrapolation_gain(const Vec3& p) const {
  double gain = 1.0;
  for (int a = 0; a < 3; ++a) {
    const AxisBasis& axis = axes_[a];
    if (p[a] >= axis.domain_lo() && p[a] <= axis.domain_hi()) continue;  // weights >= 0, summing to 1
    double w[kMaxAxisWidth];
    int index[kMaxAxisWidth];
    axis.evaluate(axis.locate(p[a], outside_), w, nullptr, index);
    double sum = 0.0;
    for (int k = 0; k < axis.width(); ++k) sum += std::abs(w[k]);
    gain *= sum;
  }
  return gain;
}

bool ControlLattice::too_far(const Vec3& p) const {
  if (outside_ != Outside::Extrapolate) return false;
  bool safe = true;
  for (int a = 0; a < 3; ++a) safe = safe && p[a] >= safe_lo_[a] && p[a] <= safe_hi_[a];
  return !safe && !(extrapolation_gain(p) <= kMaxExtrapolationGain);
}

template <class T>
void ControlLattice::refuse_row(const T* in, std::size_t row) const {
  const Vec3 x(in[3 * row], in[3 * row + 1], in[3 * row + 2]);
  Vec3 p;
  place(x, p);
  std::ostringstream msg;
  msg.precision(17);
  msg << "points: row " << row << " (" << x[0] << ", " << x[1] << ", " << x[2] << ")";
  if (!p.allFinite()) {
    msg << " lies so far from the lattice that its lattice coordinates overflow";
  } else {
    msg.precision(3);
    const double gain = extrapolation_gain(p);
    msg << " lies too far outside the lattice to extrapolate accurately: its weights' magnitudes sum to ";
    if (std::isfinite(gain)) msg << gain;
    else msg << "more than a double holds";
    msg << ", over the limit " << kMaxExtrapolationGain
        << " (docs/lattice.md, \"Far outside\"); use outside='clamp' or 'unchanged', or a larger lattice";
  }
  throw std::invalid_argument(msg.str());
}
template void ControlLattice::refuse_row(const float*, std::size_t) const;
template void ControlLattice::refuse_row(const double*, std::size_t) const;

template <class T>
bool ControlLattice::place_rows(const T* in, std::size_t n, double* parameters, std::uint8_t* status,
                                std::uint64_t* key, double* local, double* ds) const {
  bool finite = place_rows_unchecked(in, n, parameters, status, key, local, ds);
  if (outside_ != Outside::Extrapolate) return finite;
  // A row too far out to evaluate accurately is one the caller refuses, as one that overflows.
  for (std::size_t i = 0; i < n; ++i) {
    double* p = parameters + 3 * i;
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]) || !too_far(Vec3(p[0], p[1], p[2])))
      continue;
    p[0] = p[1] = p[2] = std::numeric_limits<double>::quiet_NaN();
    key[i] = still_key();
    finite = false;
  }
  return finite;
}

template <class T>
bool ControlLattice::place_rows_unchecked(const T* in, std::size_t n, double* parameters, std::uint8_t* status,
                                          std::uint64_t* key, double* local, double* ds) const {
  if (affine_) {
    Placement3 box;
    for (int e = 0; e < 9; ++e) box.to_parameters[e] = to_parameters_(e / 3, e % 3);
    for (int a = 0; a < 3; ++a) {
      box.origin[a] = origin_[a];
      box.axes[a] = {is_blender(axes_[a].kind), axes_[a].count, axes_[a].pieces(), axes_[a].domain_lo(),
                     axes_[a].domain_hi(), axes_[a].scale()};
    }
    box.outside = outside_ == Outside::Clamp ? 0 : outside_ == Outside::Unchanged ? 1 : 2;
    box.still = still_key();
    return place_in_box(box, in, n, parameters, status, key, local, ds);
  }
  bool finite = true;
  const std::uint64_t still = still_key();
  for (std::size_t i = 0; i < n; ++i) {
    Vec3 p;
    const PointStatus s = place(Vec3(in[3 * i], in[3 * i + 1], in[3 * i + 2]), p);
    for (int a = 0; a < 3; ++a) parameters[3 * i + a] = p[a];
    if (status) status[i] = static_cast<std::uint8_t>(s);
    const bool ok = p.allFinite();
    finite = finite && ok;
    key[i] = ok && displaces(s) ? cell_key(p, local + 3 * i, ds ? ds + 3 * i : nullptr) : still;
  }
  return finite;
}
template bool ControlLattice::place_rows(const float*, std::size_t, double*, std::uint8_t*, std::uint64_t*, double*,
                                         double*) const;
template bool ControlLattice::place_rows(const double*, std::size_t, double*, std::uint8_t*, std::uint64_t*, double*,
                                         double*) const;
template bool ControlLattice::place_rows_unchecked(const float*, std::size_t, double*, std::uint8_t*, std::uint64_t*,
                                                   double*, double*) const;
template bool ControlLattice::place_rows_unchecked(const double*, std::size_t, double*, std::uint8_t*,
                                                   std::uint64_t*, double*, double*) const;

PointStatus ControlLattice::place(const Vec3& x, Vec3& parameters) const {
  if (x.allFinite()) return locate(x, parameters);
  parameters = Vec3::Constant(std::numeric_limits<double>::quiet_NaN());
  return PointStatus::NotPlaced;
}

// Cell key: pieces offset by 2 (Blender's run from -2 to count), in a box of count + 4 per axis;
// one more key for points left where they are.
std::uint64_t ControlLattice::still_key() const {
  return std::uint64_t(axes_[0].count + 4) * (axes_[1].count + 4) * (axes_[2].count + 4);
}

std::array<std::int32_t, 3> ControlLattice::cell_of_key(std::uint64_t k) const {
  const std::uint64_t r0 = axes_[0].count + 4, r1 = axes_[1].count + 4, r2 = axes_[2].count + 4;
  return {int(k / (r1 * r2) % r0) - 2, int(k / r2 % r1) - 2, int(k % r2) - 2};
}

std::uint64_t ControlLattice::cell_key(const Vec3& p, double* t, double* ds) const {
  std::uint64_t k = 0;
  for (int a = 0; a < 3; ++a) {
    const AxisSpan span = axes_[a].locate(p[a], outside_);
    if (t) t[a] = span.t;
    if (ds) ds[a] = span.frozen ? 0.0 : axes_[a].scale();
    k = k * std::uint64_t(axes_[a].count + 4) + std::uint64_t(span.piece + 2);
  }
  return k;
}

LatticeBinding ControlLattice::bind(const double* points, std::size_t n) const { return bind_points(points, n); }
LatticeBinding ControlLattice::bind(const float* points, std::size_t n) const { return bind_points(points, n); }

// Lattices with too many cells to sort by counting in chunks: one stable sort of all the points.
template <class T>
void ControlLattice::sort_by_cell(LatticeBinding& b, const T* in, const std::uint64_t* key) const {
  const std::size_t n = b.size();
  const std::uint64_t still = still_key();
  auto span = [&](std::size_t i, int a) { return axes_[a].locate(b.parameters[3 * i + a], outside_); };
  Buffer<std::uint64_t> sorted_key(n);
  b.order.resize(n);
  for (std::size_t i = 0; i < n; ++i) b.order[i] = static_cast<std::uint32_t>(i);
  std::stable_sort(b.order.begin(), b.order.end(), [key](std::uint32_t x, std::uint32_t y) { return key[x] < key[y]; });
  for (std::size_t i = 0; i < n; ++i) sorted_key[i] = key[b.order[i]];
  CellIds ids(still);
  for (std::size_t i = 0; i < n; ++i) {
    const std::uint64_t k = sorted_key[i];
    if (i == 0 || k != sorted_key[i - 1]) add_run(b, ids, static_cast<std::uint32_t>(i), k, k != still, cell_of_key(k));
  }
  b.run_begin.push_back(static_cast<std::uint32_t>(n));
  Buffer<T>& sorted = sorted_points_of(b, static_cast<T*>(nullptr));
  sorted.resize(6 * n);
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const std::size_t p = b.order[i];
      const bool moves = sorted_key[i] != still;
      for (int a = 0; a < 3; ++a) {
        sorted[a * n + i] = moves ? static_cast<T>(span(p, a).t) : T(0);
        sorted[(3 + a) * n + i] = in[3 * p + a];
      }
    }
  });
}

template <class T>
void ControlLattice::cell_block(const std::array<std::int32_t, 3>& cell, T* block) const {
  const KernelAxis k[3] = {kernel_axis(axes_[0]), kernel_axis(axes_[1]), kernel_axis(axes_[2])};
  const int nv = axes_[1].count, nw = axes_[2].count;
  int index[3][kMaxAxisWidth];
  for (int a = 0; a < 3; ++a) kernel_indices(axes_[a], cell[a], index[a]);
  std::size_t e = 0;
  for (int i = 0; i < k[0].width; ++i)
    for (int j = 0; j < k[1].width; ++j)
      for (int l = 0; l < k[2].width; ++l) {
        const double* c = &offset_[3 * ((std::size_t(index[0][i]) * nv + index[1][j]) * nw + index[2][l])];
        for (int a = 0; a < 3; ++a) block[e++] = static_cast<T>(strength_ * c[a]);
      }
}

// The bound points as they were bound: the x, y, z rows of the cell-sorted structure of arrays.
template <class T>
static StoredPoints<T> stored_points(const LatticeBinding& b) {
  const Buffer<T>& sorted = sorted_points<T>(b);
  const std::size_t n = b.size();
  return StoredPoints<T>{{sorted.data() + 3 * n, sorted.data() + 4 * n, sorted.data() + 5 * n}, 1, b.order.data()};
}

void ControlLattice::check_binding(const PointBinding& binding) const {
  const auto* b = dynamic_cast<const LatticeBinding*>(&binding);
  if (!b) throw std::invalid_argument("binding: was not made by a lattice; bind the points to this lattice");
  if (b->layout != layout())
    throw std::invalid_argument("binding: was made by a lattice with another basis, resolution or rest placement; "
                                "bind the points to this lattice");
}

void ControlLattice::bound_points(const PointBinding& b, StoredPoints<float>& points) const {
  points = stored_points<float>(static_cast<const LatticeBinding&>(b));
}
void ControlLattice::bound_points(const PointBinding& b, StoredPoints<double>& points) const {
  points = stored_points<double>(static_cast<const LatticeBinding&>(b));
}
bool ControlLattice::deform_bound_impl(const PointBinding& b, float* out) const {
  return deform_sorted(static_cast<const LatticeBinding&>(b), out);
}
bool ControlLattice::deform_bound_impl(const PointBinding& b, double* out) const {
  return deform_sorted(static_cast<const LatticeBinding&>(b), out);
}
bool ControlLattice::displacement_bound_impl(const PointBinding& b, float* out, const double* w) const {
  return deform_sorted(static_cast<const LatticeBinding&>(b), out, true, w);
}
bool ControlLattice::displacement_bound_impl(const PointBinding& b, double* out, const double* w) const {
  return deform_sorted(static_cast<const LatticeBinding&>(b), out, true, w);
}

// The kernel over the binding's cell runs; the binding is this lattice's, of dtype T.
template <class T>
bool ControlLattice::deform_sorted(const LatticeBinding& b, T* out, bool displacement, const double* weights) const {
  const Buffer<T>& sorted = sorted_points<T>(b);
  const std::size_t n = b.size();
  const KernelAxis kaxes[3] = {kernel_axis(axes_[0]), kernel_axis(axes_[1]), kernel_axis(axes_[2])};
  const std::size_t block_size = 3 * std::size_t(kaxes[0].width) * kaxes[1].width * kaxes[2].width;
  // Each cell's control-point offsets, gathered once per call rather than once per run.
  const bool table = b.cells.size() * block_size <= (std::size_t(1) << 22);
  std::vector<T> blocks(table ? b.cells.size() * block_size : 0);
  if (table)
    parallel_blocks(b.cells.size() * 256, [&](std::size_t begin, std::size_t end) {
      for (std::size_t c = (begin + 255) / 256; c < (end + 255) / 256 && c < b.cells.size(); ++c)
        if (b.cell_moves[c]) cell_block(b.cells[c], &blocks[c * block_size]);
    });
  std::atomic<bool> finite{true};
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    std::vector<T> own(table ? 0 : block_size);
    bool ok = true;
    std::size_t r = std::upper_bound(b.run_begin.begin(), b.run_begin.end(), begin) - b.run_begin.begin() - 1;
    for (; r + 1 < b.run_begin.size() && b.run_begin[r] < end; ++r) {
      const std::size_t lo = std::max<std::size_t>(begin, b.run_begin[r]), hi = std::min<std::size_t>(end, b.run_begin[r + 1]);
      const std::int32_t c = b.run_cell[r];
      if (!b.cell_moves[c]) {
        for (std::size_t i = lo; i < hi; ++i)
          for (int a = 0; a < 3; ++a) out[3 * std::size_t(b.order[i]) + a] = displacement ? T(0) : sorted[(3 + a) * n + i];
        continue;
      }
      const T* block = table ? &blocks[c * block_size] : own.data();
      if (!table) cell_block(b.cells[c], own.data());
      const T* t[3] = {&sorted[lo], &sorted[n + lo], &sorted[2 * n + lo]};
      const T* x[3] = {&sorted[3 * n + lo], &sorted[4 * n + lo], &sorted[5 * n + lo]};
      ok = lattice_cell_kernel(kaxes, block, t, displacement ? nullptr : x, &b.order[lo], hi - lo, out,
                               displacement ? weights : nullptr) && ok;
    }
    if (!ok) finite = false;
  });
  return finite;
}

// Unbound points: the bound path chunk by chunk, with every buffer in cache and nothing kept.
template <class T>
bool ControlLattice::deform_points(const T* in, T* out, std::size_t n) const {
  const std::uint64_t still = still_key();
  if (still + 1 > kCountingSortKeys) {  // too many cells to sort by counting per chunk
    for (std::size_t i = 0; i < 3 * n; ++i)
      if (!std::isfinite(in[i])) return false;
    return deform_sorted(bind_points(in, n), out);
  }
  const KernelAxis kaxes[3] = {kernel_axis(axes_[0]), kernel_axis(axes_[1]), kernel_axis(axes_[2])};
  const std::size_t block_size = 3 * std::size_t(kaxes[0].width) * kaxes[1].width * kaxes[2].width;
  std::atomic<bool> finite{true};
  OverflowRows overflow;
  parallel_blocks(n, [&](std::size_t begin, std::size_t end) {
    constexpr std::size_t kChunk = 8192;
    ChunkByCell chunk(still + 1, kChunk);
    std::vector<double> local(3 * kChunk), params(3 * kChunk);
    std::vector<T> soa(6 * kChunk), block(block_size);
    bool ok = true, results_finite = true;  // input rows, and the kernel's results
    for (std::size_t c = begin; c < end && ok; c += kChunk) {
      const std::size_t m = std::min(kChunk, end - c);
      if (!place_rows(in + 3 * c, m, params.data(), nullptr, chunk.key.data(), local.data(), nullptr)) {
        // A row not finite is the generic path's to name; a finite one that overflows is noted.
        for (std::size_t i = 0; i < m && ok; ++i) {
          if (std::isfinite(params[3 * i]) && std::isfinite(params[3 * i + 1]) && std::isfinite(params[3 * i + 2]))
            continue;
          const T* x = in + 3 * (c + i);
          if (std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2])) overflow.note(c + i);
          ok = false;
        }
        if (!ok) break;
      }
      chunk.sort(c, m, [&](std::size_t i, std::size_t to) {
        const bool still_row = chunk.key[i] == still;
        for (int a = 0; a < 3; ++a) {
          soa[a * kChunk + to] = still_row ? T(0) : static_cast<T>(local[3 * i + a]);
          soa[(3 + a) * kChunk + to] = in[3 * (c + i) + a];
        }
      });
      const std::uint32_t* order = chunk.order.data();
      chunk.runs(m, [&](std::uint64_t k, std::size_t lo, std::size_t hi) {
        if (k == still) {
          for (std::size_t i = lo; i < hi; ++i)
            for (int a = 0; a < 3; ++a) out[3 * std::size_t(order[i]) + a] = soa[(3 + a) * kChunk + i];
          return;
        }
        cell_block(cell_of_key(k), block.data());
        const T* t[3] = {&soa[lo], &soa[kChunk + lo], &soa[2 * kChunk + lo]};
        const T* x[3] = {&soa[3 * kChunk + lo], &soa[4 * kChunk + lo], &soa[5 * kChunk + lo]};
        results_finite = lattice_cell_kernel(kaxes, block.data(), t, x, &order[lo], hi - lo, out) && results_finite;
      });
    }
    if (!ok || !results_finite) finite = false;
  });
  if (overflow.any()) refuse_row(in, overflow.first());
  return finite;
}

bool ControlLattice::deform_impl(const float* in, float* out, std::size_t n) const { return deform_points(in, out, n); }
bool ControlLattice::deform_impl(const double* in, double* out, std::size_t n) const {
  return deform_points(in, out, n);
}

template void ControlLattice::cell_block<float>(const std::array<std::int32_t, 3>&, float*) const;
template void ControlLattice::cell_block<double>(const std::array<std::int32_t, 3>&, double*) const;

WeightTable ControlLattice::weights_matrix(const LatticeBinding& b) const {
  if (b.layout != layout())
    throw std::invalid_argument("binding: was made by a lattice with another basis, resolution or rest placement");
  WeightTable m;  // indptr starts as {0}
  m.indptr.reserve(b.size() + 1);
  const int nv = axes_[1].count, nw = axes_[2].count;
  std::vector<std::pair<std::int32_t, double>> row;
  for (std::size_t i = 0; i < b.size(); ++i) {
    row.clear();
    if (displaces(static_cast<PointStatus>(b.status[i]))) {
      AxisWeights ax[3];
      for (int a = 0; a < 3; ++a) {
        axes_[a].evaluate(axes_[a].locate(b.parameters[3 * i + a], outside_), ax[a].w, nullptr, ax[a].index);
        ax[a].width = axes_[a].width();
      }
      for (int p = 0; p < ax[0].width; ++p)
        for (int q = 0; q < ax[1].width; ++q)
          for (int r = 0; r < ax[2].width; ++r) {
            const double w = ax[0].w[p] * ax[1].w[q] * ax[2].w[r];
            if (!std::isfinite(w))  // 'extrapolate' far outside: the polynomials overflow
              throw std::invalid_argument("binding: point " + std::to_string(i) + " lies so far outside the lattice "
                                          "that its extrapolated weights overflow");
            if (w != 0.0) row.emplace_back((ax[0].index[p] * nv + ax[1].index[q]) * nw + ax[2].index[r], w);
          }
      std::sort(row.begin(), row.end());
    }
    for (std::size_t k = 0; k < row.size(); ++k) {
      if (!m.indices.empty() && m.indptr.back() < std::int64_t(m.indices.size()) && m.indices.back() == row[k].first)
        m.values.back() += row[k].second;
      else {
        m.indices.push_back(row[k].first);
        m.values.push_back(row[k].second);
      }
    }
    m.indptr.push_back(static_cast<std::int64_t>(m.indices.size()));
  }
  return m;
}

}  // namespace deformkit
