// Time and peak memory of solve_grid_stencil against CHOLMOD on Mesh Deform's grid system (a figure
// of balls standing in for the cage, cpp/tests/numerics/grid_stencil_shapes.hpp), one configuration
// per process so that the peak resident memory is that configuration's. Usage:
//   bench_grid_stencil <multigrid|cholmod> <figure|ball> <cells a side> <right-hand sides> [block] [tolerance]
// figure: a character's shape filling 4.5% of the cube (Ogre's cage fills 3.8% of its cubic box);
// ball: 29% (FireHydrant's cage: 23%). DK_GRID_SCALE and DK_GRID_SMOOTHING override the multigrid
// settings (for tuning).
// prints one line of key=value pairs (docs/benchmarks.md, "Grid solver").
#include "numerics/grid_stencil_solver.hpp"
#include "numerics/grid_stencil_shapes.hpp"
#include "deformkit/numerics/sparse_cholesky.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

using namespace deformkit;

namespace {

double seconds_since(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

double peak_mib() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_maxrss) / 1024.0;
}

// User and system CPU time of the whole process: on a machine shared with other work it shows the
// solver's own cost when wall-clock time does not.
double cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

double resident_mib() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return double(resident) * 4096.0 / (1024.0 * 1024.0);
}

// Cage-vertex-like boundary values: a bump around a point of the figure's surface per column.
Eigen::Vector3d seed(int k) {
  const double golden = 2.399963229728653, z = 1.0 - 2.0 * (k + 0.5) / 997.0, r = std::sqrt(1.0 - z * z);
  return Eigen::Vector3d(0.5 + 0.4 * r * std::cos(golden * k), 0.5 + 0.15 * r * std::sin(golden * k), 0.5 + 0.4 * z);
}

void fill_bumps(const test::ShapeSystem& s, int first, Eigen::Ref<Eigen::MatrixXd> b) {
  for (Eigen::Index c = 0; c < b.cols(); ++c) {
    const Eigen::Vector3d at = seed(first + int(c));
    for (const test::CutEdge& e : s.cuts) b(e.unknown, c) += e.weight * std::exp(-(e.hit - at).squaredNorm() / 0.045);
  }
}

SparseMatrix sparse_matrix(const test::ShapeSystem& s) {
  std::vector<Eigen::Triplet<double>> e;
  const int n = s.stencil.cells[0];
  const int stride[3] = {1, n, n * n};
  for (int c = 0; c < n * n * n; ++c) {
    const int u = s.stencil.unknown[std::size_t(c)];
    if (u < 0) continue;
    e.emplace_back(u, u, s.stencil.diagonal[std::size_t(u)]);
    for (int d = 0; d < 6; ++d)
      if (s.stencil.coupling[std::size_t(u)][std::size_t(d)] != 0.0)
        e.emplace_back(u, s.stencil.unknown[std::size_t(c + (d % 2 ? 1 : -1) * stride[d / 2])], -s.stencil.coupling[std::size_t(u)][std::size_t(d)]);
  }
  SparseMatrix a(Eigen::Index(s.centre.size()), Eigen::Index(s.centre.size()));
  a.setFromTriplets(e.begin(), e.end());
  return a;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 5) {
    std::fprintf(stderr, "usage: %s <multigrid|cholmod> <figure|ball> <cells a side> <right-hand sides> [block=16] [tolerance=1e-8]\n", argv[0]);
    return 2;
  }
  const std::string method = argv[1], shape = argv[2];
  const int n = std::atoi(argv[3]), columns = std::atoi(argv[4]);
  const int block = argc > 5 ? std::atoi(argv[5]) : 16;
  const double tol = argc > 6 ? std::atof(argv[6]) : 1e-8;
  numerics::GridSolveOptions options;
  if (const char* v = std::getenv("DK_GRID_SCALE")) options.multigrid.correction_scale = std::atof(v);
  if (const char* v = std::getenv("DK_GRID_SMOOTHING")) options.multigrid.smoothing = std::atoi(v);
  auto start = std::chrono::steady_clock::now();
  const test::ShapeSystem s = test::shape_system(shape == "ball" ? test::one_ball() : test::figure(), n);
  const double build = seconds_since(start);
  const double before = resident_mib();
  double checksum = 0.0, worst = 0.0;
  // The true residual of a sample of columns, measured outside the solver.
  const SparseMatrix a = sparse_matrix(s);
  auto check = [&](int first, const Eigen::Ref<const Eigen::MatrixXd>& x) {
    checksum += x.sum();
    if (first % 97 != 0) return;
    Eigen::MatrixXd b = Eigen::MatrixXd::Zero(x.rows(), 1);
    fill_bumps(s, first, b);
    worst = std::max(worst, (b.col(0) - a * x.col(0)).norm() / b.col(0).norm());
  };
  start = std::chrono::steady_clock::now();
  const double cpu_start = cpu_seconds();
  std::string extra;
  if (method == "multigrid") {
    numerics::GridSolveReport report;
    numerics::solve_grid_stencil(
        s.stencil, columns, block, [&](int first, Eigen::Ref<Eigen::MatrixXd> b) { fill_bumps(s, first, b); }, check, tol, options, &report);
    int most = 0;
    for (int it : report.iterations) most = std::max(most, it);
    extra = " levels=" + std::to_string(report.levels) + " most_iterations=" + std::to_string(most);
  } else {
    SparseCholesky chol;
    if (!chol.factorize(a, CholeskyKind::Supernodal)) return 1;
    extra = " factor_nonzeros=" + std::to_string(chol.factor_nonzeros()) + " factor_s=" + std::to_string(seconds_since(start));
    for (int first = 0; first < columns; first += block) {
      Eigen::MatrixXd b = Eigen::MatrixXd::Zero(Eigen::Index(s.centre.size()), std::min(block, columns - first));
      fill_bumps(s, first, b);
      check(first, chol.solve(b));
    }
  }
  const double solve = seconds_since(start), solve_cpu = cpu_seconds() - cpu_start;
  std::printf("method=%s shape=%s cells=%d unknowns=%zu columns=%d block=%d tol=%g build_s=%.2f solve_s=%.2f solve_cpu_s=%.2f peak_mib=%.0f before_solve_mib=%.0f worst_residual=%.2e checksum=%.9g%s\n",
              method.c_str(), shape.c_str(), n, s.centre.size(), columns, block, tol, build, solve, solve_cpu, peak_mib(), before, worst, checksum, extra.c_str());
  return 0;
}
