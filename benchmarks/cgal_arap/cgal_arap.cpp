// cgal_arap: CGAL's Surface_mesh_deformation (ORIGINAL_ARAP, Sorkine and Alexa 2007) timed on a
// mesh written by benchmarks/bench_surface.py, for the side-by-side comparison with deformkit's
// SurfaceDeformer(method='arap'). Benchmark-only; built by bench_surface.py into build/bench-cgal.
//
//   cgal_arap INPUT [--repeats R] [--bind-repeats B] [--result-iterations N] [--out PATH]
//             [--out-dk-weights PATH]
//
// INPUT (native little-endian): the 8 bytes "DKCGAL01", int64 n_points, n_triangles, n_anchors,
// n_handles, then float64 points[n_points][3], int64 triangles[n_triangles][3], int64
// anchors[n_anchors], int64 handles[n_handles], float64 targets[n_handles][3].
//
// Set-up: CGAL::Surface_mesh<Simple_cartesian<double>::Point_3>; the region of interest is every
// vertex that has a face (the whole mesh), the control vertices are anchors + handles (anchors keep
// their rest position as target, handles get the targets). A triangle that Surface_mesh rejects
// (non-manifold) ends the run with an error: the problem would no longer be the same. Template defaults otherwise: cotangent
// weights (CGAL::Weights::Cotangent_weight, each negative cotangent clamped to 0), Eigen's SparseLU
// with COLAMD ordering on the ROI system (identity rows for control vertices), polar-decomposition
// closest rotations with an SVD fallback.
//
// What is timed (std::chrono::steady_clock, seconds):
//   bind    = Surface_mesh_deformation constructor (halfedge weights) + insert_roi_vertices +
//             insert_control_vertices + preprocess() (region of solution, assembly, factorisation);
//             one untimed warm-up, then B timed binds, each a new object on the rest mesh.
//   deform k = deform(k, 0.0) alone. CGAL's deform() warm-starts: it continues from the current
//             solution and the rotations of the previous call. So before every call (untimed)
//             reset() puts the ROI back at rest and the rotations to identity, and
//             set_target_position() writes the handle targets again: every call does the same
//             work from the same state. One iteration of deform() = global step (3 back-
//             substitutions with the current rotations) + local step (one rotation per vertex);
//             tolerance 0 skips the energy evaluation. The positions after deform(k) are those of
//             the k-th global step, so deform(k + 1) matches deformkit's iterations=k (which does
//             k + 1 global steps, the first with identity rotations).
//   One untimed warm-up, then R timed calls, for k = 1, 2 and 11.
// The result: reset, targets, deform(N, 0.0), all points written to --out as float64 [n][3].
// --out-dk-weights: the same result (untimed) from a second Surface_mesh_deformation whose weight
// calculator returns deformkit's edge weights instead of CGAL's: w_ij = (cot a + cot b) / 2 with each
// cotangent clamped to +-1e4 (a zero-area corner gets +-1e4 by the sign of its dot product), then
// raised to at least 1e-3 x the mean of the positive w_ij. With the same weights both programs
// solve the same equations, so that result isolates the solvers from the weighting rules.
// Output: one JSON object on stdout.
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_deformation.h>
#include <CGAL/Weights/cotangent_weights.h>
#include <CGAL/version.h>

#include <Eigen/Core>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace {

using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using Vertex = Mesh::Vertex_index;
using Deformation = CGAL::Surface_mesh_deformation<Mesh, CGAL::Default, CGAL::Default, CGAL::ORIGINAL_ARAP>;
using Clock = std::chrono::steady_clock;

// deformkit's weights (cotangent_laplacian.cpp + with_positive_weights in surface_deformer.cpp),
// one per edge. Both halfedges of an edge return it; CGAL's ORIGINAL_ARAP uses w(h) + w(opposite h)
// in the matrix and w(h) R_i + w(opp) R_j on the right-hand side, i.e. twice deformkit's system,
// which has the same solution.
std::vector<double> deformkit_edge_weights(const Mesh& mesh) {
  constexpr double kMaxCotangent = 1e4;
  std::vector<double> w(mesh.number_of_edges(), 0.0);
  for (auto f : mesh.faces())
    for (auto h : CGAL::halfedges_around_face(mesh.halfedge(f), mesh)) {
      // the corner opposite the edge of h
      const Point& a = mesh.point(mesh.target(mesh.next(h)));
      const Point& b = mesh.point(mesh.source(h));
      const Point& c = mesh.point(mesh.target(h));
      const Kernel::Vector_3 u = b - a, v = c - a;
      const double cross = std::sqrt(CGAL::cross_product(u, v).squared_length()), dot = u * v;
      double cot = cross > 0.0 ? dot / cross : (dot >= 0.0 ? kMaxCotangent : -kMaxCotangent);
      cot = std::clamp(cot, -kMaxCotangent, kMaxCotangent);
      w[mesh.edge(h).idx()] += 0.5 * cot;
    }
  double sum = 0;
  std::size_t count = 0;
  for (double x : w)
    if (x > 0) sum += x, ++count;
  const double floor = count ? 1e-3 * sum / double(count) : 1e-3;
  for (double& x : w) x = std::max(x, floor);
  return w;
}

struct DeformkitWeights {  // a model of SurfaceMeshDeformationWeights
  using Triangle_mesh = Mesh;
  const std::vector<double>* edge_weight = nullptr;
  template <class VertexPointMap>
  double operator()(Mesh::Halfedge_index h, const Mesh& mesh, VertexPointMap) const {
    return (*edge_weight)[mesh.edge(h).idx()];
  }
};
using DeformationDkWeights =
    CGAL::Surface_mesh_deformation<Mesh, CGAL::Default, CGAL::Default, CGAL::ORIGINAL_ARAP, DeformkitWeights>;

struct Input {
  std::vector<double> points, targets;
  std::vector<std::int64_t> triangles, anchors, handles;
};

[[noreturn]] void fail(const std::string& message, int code = 2) {
  std::string escaped;
  for (char c : message) escaped += (c == '"' || c == '\\') ? std::string("\\") + c : std::string(1, c);
  std::printf("{\"ok\": false, \"error\": \"%s\"}\n", escaped.c_str());
  std::exit(code);
}

template <class T>
void read_array(std::ifstream& in, std::vector<T>& v, std::int64_t count, const char* what) {
  if (count < 0 || count > (std::int64_t(1) << 32)) fail(std::string("input: bad count for ") + what);
  v.resize(std::size_t(count));
  in.read(reinterpret_cast<char*>(v.data()), std::streamsize(count * std::int64_t(sizeof(T))));
  if (!in) fail(std::string("input: truncated in ") + what);
}

Input read_input(const char* path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(std::string("cannot open ") + path);
  char magic[8];
  in.read(magic, 8);
  if (!in || std::memcmp(magic, "DKCGAL01", 8) != 0) fail("input: not a DKCGAL01 file");
  std::int64_t n[4];
  in.read(reinterpret_cast<char*>(n), sizeof n);
  if (!in) fail("input: truncated header");
  Input r;
  read_array(in, r.points, 3 * n[0], "points");
  read_array(in, r.triangles, 3 * n[1], "triangles");
  read_array(in, r.anchors, n[2], "anchors");
  read_array(in, r.handles, n[3], "handles");
  read_array(in, r.targets, 3 * n[3], "targets");
  const std::int64_t np = n[0];
  auto check = [&](const std::vector<std::int64_t>& idx, const char* what) {
    for (std::int64_t i : idx)
      if (i < 0 || i >= np) fail(std::string("input: ") + what + " index out of range");
  };
  check(r.triangles, "triangle");
  check(r.anchors, "anchor");
  check(r.handles, "handle");
  return r;
}

double seconds(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double>(b - a).count(); }

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t m = v.size() / 2;
  return v.size() % 2 ? v[m] : 0.5 * (v[m - 1] + v[m]);
}

std::string json_list(const std::vector<double>& v) {
  std::string s = "[";
  char buf[32];
  for (std::size_t i = 0; i < v.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%.6g", i ? ", " : "", v[i]);
    s += buf;
  }
  return s + "]";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) fail("usage: cgal_arap INPUT [--repeats R] [--bind-repeats B] [--result-iterations N] [--out PATH]");
  int repeats = 5, bind_repeats = 3;
  unsigned result_iterations = 11;
  std::string out_path, out_dk_path;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc) fail("missing value after " + a);
    if (a == "--repeats") repeats = std::max(1, std::atoi(argv[++i]));
    else if (a == "--bind-repeats") bind_repeats = std::max(1, std::atoi(argv[++i]));
    else if (a == "--result-iterations") result_iterations = unsigned(std::max(1, std::atoi(argv[++i])));
    else if (a == "--out") out_path = argv[++i];
    else if (a == "--out-dk-weights") out_dk_path = argv[++i];
    else fail("unknown option " + a);
  }
  const Input input = read_input(argv[1]);
  const std::size_t n = input.points.size() / 3, nt = input.triangles.size() / 3;

  // The mesh: vertex i of the input is Vertex(i) (Surface_mesh numbers vertices in insertion order).
  Mesh mesh;
  mesh.reserve(Mesh::size_type(n), Mesh::size_type(3 * nt / 2 + 16), Mesh::size_type(nt));
  for (std::size_t i = 0; i < n; ++i) mesh.add_vertex(Point(input.points[3 * i], input.points[3 * i + 1], input.points[3 * i + 2]));
  std::size_t rejected = 0;
  std::int64_t first_rejected = -1;
  for (std::size_t t = 0; t < nt; ++t) {
    const auto* f = &input.triangles[3 * t];
    if (mesh.add_face(Vertex(Mesh::size_type(f[0])), Vertex(Mesh::size_type(f[1])), Vertex(Mesh::size_type(f[2]))) ==
        Mesh::null_face()) {
      if (first_rejected < 0) first_rejected = std::int64_t(t);
      ++rejected;
    }
  }
  if (rejected)
    fail("CGAL::Surface_mesh rejected " + std::to_string(rejected) + " of " + std::to_string(nt) +
         " triangles (non-manifold or inconsistently oriented; first: triangle " + std::to_string(first_rejected) +
         "); Surface_mesh_deformation needs a valid triangulated halfedge mesh", 3);

  // Region of interest: every vertex with a face; control vertices: anchors + handles. A vertex
  // without a face stays out of both (an isolated handle is put at its target in the output).
  std::vector<Vertex> roi, controls;
  for (Vertex v : mesh.vertices())
    if (!mesh.is_isolated(v)) roi.push_back(v);
  std::size_t isolated_controls = 0;
  for (const auto* list : {&input.anchors, &input.handles})
    for (std::int64_t i : *list) {
      const Vertex v{Mesh::size_type(i)};
      if (mesh.is_isolated(v)) ++isolated_controls;
      else controls.push_back(v);
    }
  if (controls.empty()) fail("no anchor or handle has a face");

  // Edges whose (clamped) cotangent weight is 0, with CGAL's own weight functor (both halfedges of an
  // edge get the same value: half the sum of the clamped cotangents of the opposite angles).
  std::size_t zero_weight_edges = 0;
  {
    const CGAL::Weights::Cotangent_weight<Mesh> weight;
    for (auto e : mesh.edges())
      if (weight(mesh.halfedge(e), mesh, mesh.points()) <= 0.0) ++zero_weight_edges;
  }

  // bind
  std::vector<double> t_bind, t_weights, t_preprocess;
  std::unique_ptr<Deformation> deformer;
  for (int rep = 0; rep <= bind_repeats; ++rep) {
    deformer.reset();
    const auto t0 = Clock::now();
    deformer = std::make_unique<Deformation>(mesh);  // computes every halfedge weight
    const auto t1 = Clock::now();
    deformer->insert_roi_vertices(roi.begin(), roi.end());
    deformer->insert_control_vertices(controls.begin(), controls.end());
    const bool ok = deformer->preprocess();
    const auto t2 = Clock::now();
    if (!ok) fail("preprocess() failed: the factorisation of the ROI system did not succeed (rank deficient: a "
                  "part of the mesh without control vertex, or zero weights cutting vertices off)", 4);
    if (rep == 0) continue;  // warm-up
    t_bind.push_back(seconds(t0, t2));
    t_weights.push_back(seconds(t0, t1));
    t_preprocess.push_back(seconds(t1, t2));
  }

  auto start = [&]() {  // same state before every deform(): rest positions, identity rotations, targets
    deformer->reset();
    for (std::size_t h = 0; h < input.handles.size(); ++h)
      deformer->set_target_position(Vertex(Mesh::size_type(input.handles[h])),
                                    Point(input.targets[3 * h], input.targets[3 * h + 1], input.targets[3 * h + 2]));
  };
  auto timed_deform = [&](unsigned k) {
    start();
    const auto t0 = Clock::now();
    deformer->deform(k, 0.0);
    return seconds(t0, Clock::now());
  };
  const unsigned ks[] = {1, 2, 11};
  std::vector<std::vector<double>> t_deform;
  for (unsigned k : ks) {
    timed_deform(k);  // warm-up
    std::vector<double> ts;
    for (int r = 0; r < repeats; ++r) ts.push_back(timed_deform(k));
    t_deform.push_back(ts);
  }
  const double iteration = (median(t_deform[2]) - median(t_deform[0])) / 10.0;

  // the result
  start();
  deformer->deform(result_iterations, 0.0);
  auto points_of = [&]() {
    std::vector<double> out(3 * n);
    for (std::size_t i = 0; i < n; ++i) {
      const Point& p = mesh.point(Vertex(Mesh::size_type(i)));
      out[3 * i] = p.x(), out[3 * i + 1] = p.y(), out[3 * i + 2] = p.z();
    }
    for (std::size_t h = 0; h < input.handles.size(); ++h)
      if (mesh.is_isolated(Vertex(Mesh::size_type(input.handles[h]))))
        for (int c = 0; c < 3; ++c) out[3 * input.handles[h] + c] = input.targets[3 * h + c];
    return out;
  };
  auto write = [&](const std::string& path, const std::vector<double>& out) {
    std::ofstream f(path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(out.data()), std::streamsize(out.size() * sizeof(double)));
    if (!f) fail("cannot write " + path);
  };
  const std::vector<double> out = points_of();
  double handle_error = 0, anchor_error = 0, max_displacement = 0;
  for (std::size_t h = 0; h < input.handles.size(); ++h)
    for (int c = 0; c < 3; ++c)
      handle_error = std::max(handle_error, std::abs(out[3 * input.handles[h] + c] - input.targets[3 * h + c]));
  for (std::int64_t a : input.anchors)
    for (int c = 0; c < 3; ++c) anchor_error = std::max(anchor_error, std::abs(out[3 * a + c] - input.points[3 * a + c]));
  bool finite = true;
  for (std::size_t i = 0; i < n; ++i) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c) {
      finite = finite && std::isfinite(out[3 * i + c]);
      d2 += (out[3 * i + c] - input.points[3 * i + c]) * (out[3 * i + c] - input.points[3 * i + c]);
    }
    max_displacement = std::max(max_displacement, std::sqrt(d2));
  }
  if (!out_path.empty()) write(out_path, out);
  deformer->reset();  // the mesh back at rest
  deformer.reset();

  bool dk_ok = true;
  if (!out_dk_path.empty()) {  // untimed: the same problem with deformkit's weights
    const std::vector<double> table = deformkit_edge_weights(mesh);
    DeformationDkWeights d(mesh, CGAL::get_initialized_vertex_index_map(mesh),
                           CGAL::get_initialized_halfedge_index_map(mesh), get(CGAL::vertex_point, mesh),
                           DeformkitWeights{&table});
    d.insert_roi_vertices(roi.begin(), roi.end());
    d.insert_control_vertices(controls.begin(), controls.end());
    dk_ok = d.preprocess();
    if (dk_ok) {
      for (std::size_t h = 0; h < input.handles.size(); ++h)
        d.set_target_position(Vertex(Mesh::size_type(input.handles[h])),
                              Point(input.targets[3 * h], input.targets[3 * h + 1], input.targets[3 * h + 2]));
      d.deform(result_iterations, 0.0);
      write(out_dk_path, points_of());
      d.reset();
    }
  }

  std::printf("{\"ok\": true, \"cgal_version\": \"%s\", \"eigen_version\": \"%d.%d.%d\", \"algorithm\": \"ORIGINAL_ARAP\",\n",
              CGAL_VERSION_STR, EIGEN_WORLD_VERSION, EIGEN_MAJOR_VERSION, EIGEN_MINOR_VERSION);
  std::printf(" \"vertices\": %zu, \"triangles\": %zu, \"edges\": %zu, \"roi\": %zu, \"controls\": %zu, "
              "\"isolated_controls\": %zu, \"zero_weight_edges\": %zu,\n",
              n, nt, std::size_t(mesh.number_of_edges()), roi.size(), controls.size(), isolated_controls,
              zero_weight_edges);
  std::printf(" \"bind\": %.6g, \"bind_all\": %s, \"bind_weights\": %.6g, \"bind_preprocess\": %.6g,\n", median(t_bind),
              json_list(t_bind).c_str(), median(t_weights), median(t_preprocess));
  for (std::size_t i = 0; i < t_deform.size(); ++i)
    std::printf(" \"deform_%u\": %.6g, \"deform_%u_all\": %s,\n", ks[i], median(t_deform[i]), ks[i],
                json_list(t_deform[i]).c_str());
  std::printf(" \"iteration\": %.6g, \"repeats\": %d, \"bind_repeats\": %d,\n", iteration, repeats, bind_repeats);
  std::printf(" \"result_iterations\": %u, \"result_finite\": %s, \"handle_error\": %.3g, \"anchor_error\": %.3g, "
              "\"max_displacement\": %.6g",
              result_iterations, finite ? "true" : "false", handle_error, anchor_error, max_displacement);
  if (!out_dk_path.empty()) std::printf(",\n \"dk_weights_preprocess_ok\": %s", dk_ok ? "true" : "false");
  std::printf("}\n");
  return 0;
}
