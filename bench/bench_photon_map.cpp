// Benchmark of the photon maps: the sorted spatial hash grid (Hachisuka and Jensen 2010, "Parallel
// Progressive Photon Mapping on GPUs") and the nanoflann kd-tree (for Jensen 1996, "Global Illumination
// using Photon Maps").
//
// Build: cmake --build build/py --target caustica_bench_photon_map   (after `make build`)
// Run:   ./build/py/caustica_bench_photon_map [photons=1000000] [queries=200000]
//
// Photons lie uniformly (by area) on the five walls of a unit Cornell box and on a sphere of radius 0.2 in
// it, with random directions and powers: a photon map's typical geometry (2D manifolds in 3D). The range
// radius is chosen for ~50 photons per query on a flat wall, r = sqrt(50 / (pi * density)), and the mean
// count actually found is reported. Query points are fresh random surface points in random order (no
// coherence between consecutive queries, unlike pixels of an image: the worst case for the caches). The
// grid's cells are 2r (a query visits 2x2x2 cells) or r (3x3x3 smaller cells). kNN queries have no radius
// limit (max_radius = inf). Timings are the best of 3 runs (load from other work only slows a run
// down); "threads" is 1 (a tbb::global_control) or all. The kd-tree build (nanoflann 1.4.3) is serial.
// The last lines are Markdown table rows for bench/RESULTS.md; CPU taken by other processes during the
// run (from /proc/stat, less this process's CPU time) is printed so that noisy runs can be spotted.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
#include <vector>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include "caustica/base/rng.h"
#include "caustica/photon/hash_grid.h"
#include "caustica/photon/kdtree.h"

using namespace caustica;

namespace {

double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

double best_of(int reps, const std::function<void()>& f) {
  double best = 1e300;
  for (int i = 0; i < reps; ++i) {
    double t0 = now();
    f();
    best = std::min(best, now() - t0);
  }
  return best;
}

// Busy jiffies of the whole machine (user + nice + system + irq + softirq + steal) and this process's CPU.
double machine_busy_seconds() {
  std::ifstream f("/proc/stat");
  std::string cpu;
  unsigned long long v[8] = {0};
  f >> cpu;
  for (auto& x : v) f >> x;
  return double(v[0] + v[1] + v[2] + v[5] + v[6] + v[7]) / double(sysconf(_SC_CLK_TCK));
}
double own_cpu_seconds() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_utime.tv_sec + u.ru_stime.tv_sec) + 1e-6 * double(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

// A point uniform by area on the box walls (floor, ceiling, back, left, right of [0,1]^3) or the sphere
// (centre (0.5, 0.3, 0.5), radius 0.2); returns it with its surface normal.
struct SurfacePoint {
  Vec3f p, n;
};
constexpr float kSphereR = 0.2f;
SurfacePoint sample_surface(PCG32& rng) {
  const float sphere_area = 4.f * kPi * kSphereR * kSphereR;
  float pick = rng.next_float() * (5.f + sphere_area);
  float u = rng.next_float(), v = rng.next_float();
  if (pick < 1.f) return {Vec3f(u, 0.f, v), Vec3f(0, 1, 0)};
  if (pick < 2.f) return {Vec3f(u, 1.f, v), Vec3f(0, -1, 0)};
  if (pick < 3.f) return {Vec3f(u, v, 0.f), Vec3f(0, 0, 1)};
  if (pick < 4.f) return {Vec3f(0.f, u, v), Vec3f(1, 0, 0)};
  if (pick < 5.f) return {Vec3f(1.f, u, v), Vec3f(-1, 0, 0)};
  float z = 1.f - 2.f * u, r = std::sqrt(std::max(0.f, 1.f - z * z)), phi = 2.f * kPi * v;
  Vec3f n(r * std::cos(phi), r * std::sin(phi), z);
  return {Vec3f(0.5f, 0.3f, 0.5f) + n * kSphereR, n};
}

std::vector<Photon> make_photons(size_t n, uint64_t seed) {
  std::vector<Photon> out(n);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 65536), [&](const tbb::blocked_range<size_t>& r) {
    PCG32 rng(r.begin(), seed);
    for (size_t i = r.begin(); i != r.end(); ++i) {
      SurfacePoint s = sample_surface(rng);
      Frame f(s.n);
      float z = rng.next_float(), phi = 2.f * kPi * rng.next_float(), sr = std::sqrt(1.f - z * z);
      out[i].p = s.p;
      out[i].wi = f.to_world(Vec3f(sr * std::cos(phi), sr * std::sin(phi), z));
      out[i].power = RGB(rng.next_float(), rng.next_float(), rng.next_float()) * 10.f;
      out[i].flags = rng.next_u32() & 3u;
    }
  });
  return out;
}

std::string cpu_model() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line))
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown CPU";
}

}  // namespace

int main(int argc, char** argv) {
  const size_t n = argc > 1 ? size_t(std::atof(argv[1])) : 1000000;
  const size_t nq = argc > 2 ? size_t(std::atof(argv[2])) : 200000;
  const int cores = int(std::thread::hardware_concurrency());
  const double busy0 = machine_busy_seconds(), own0 = own_cpu_seconds(), wall0 = now();

  std::vector<Photon> photons = make_photons(n, 1);
  std::vector<Vec3f> queries(nq);
  {
    PCG32 rng(12345, 2);
    for (auto& q : queries) q = sample_surface(rng).p;
  }
  const float area = 5.f + 4.f * kPi * kSphereR * kSphereR;
  const float radius = std::sqrt(50.f / (kPi * float(n) / area));
  Bounds3 bounds;
  bounds.extend(Vec3f(0.f));
  bounds.extend(Vec3f(1.f));
  std::printf("%zu photons, %zu queries, radius %.5f (cell %.5f), %d cores\n", n, nq, radius, 2 * radius, cores);

  // --- builds
  PhotonHashGrid grid, sgrid;
  PhotonKdTree tree;
  double t_grid_all = best_of(3, [&] { grid.build(photons, bounds, 2.f * radius); });
  double t_grid_1;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    t_grid_1 = best_of(3, [&] { grid.build(photons, bounds, 2.f * radius); });
  }
  PhotonHashGrid grid_r;  // cells of side r: a query visits 3x3x3 cells, but they are smaller
  double t_grid_r_all = best_of(3, [&] { grid_r.build(photons, bounds, radius); });
  double t_sgrid_all = best_of(3, [&] { sgrid.build(photons, bounds, 2.f * radius, true, 7); });
  double t_tree = best_of(3, [&] { tree.build(photons); });
  const double per_m = 1e6 / double(n);

  // --- range queries: the grid (sum of power and count) and the kd-tree (indices, then the same sums)
  PhotonGridView view = grid.view();
  std::atomic<uint64_t> found_grid{0}, found_tree{0};
  auto grid_range = [&](size_t lo, size_t hi) {
    uint64_t cnt = 0;
    RGB acc(0.f);
    for (size_t i = lo; i < hi; ++i)
      view.query(queries[i], radius, [&](const Photon& ph) {
        acc += ph.power;
        ++cnt;
      });
    found_grid += cnt;
    if (acc.x < 0.f) std::printf("impossible\n");
  };
  tbb::enumerable_thread_specific<std::vector<uint32_t>> tls;
  auto tree_range = [&](size_t lo, size_t hi) {
    std::vector<uint32_t>& out = tls.local();
    uint64_t cnt = 0;
    RGB acc(0.f);
    for (size_t i = lo; i < hi; ++i) {
      tree.range(queries[i], radius, out);
      for (uint32_t j : out) acc += tree.photon(j).power;
      cnt += out.size();
    }
    found_tree += cnt;
    if (acc.x < 0.f) std::printf("impossible\n");
  };
  const size_t k = 50;
  auto tree_knn = [&](size_t lo, size_t hi) {
    uint32_t idx[k];
    float d2[k];
    RGB acc(0.f);
    for (size_t i = lo; i < hi; ++i) {
      size_t m = tree.knn(queries[i], k, kInf, idx, d2);
      for (size_t j = 0; j < m; ++j) acc += tree.photon(idx[j]).power;
    }
    if (acc.x < 0.f) std::printf("impossible\n");
  };
  auto run_serial = [&](auto& f) { return best_of(3, [&] { f(0, nq); }); };
  auto run_parallel = [&](auto& f) {
    return best_of(3, [&] {
      tbb::parallel_for(tbb::blocked_range<size_t>(0, nq, 1024),
                        [&](const tbb::blocked_range<size_t>& r) { f(r.begin(), r.end()); });
    });
  };
  double q_grid_1 = run_serial(grid_range), q_grid_all = run_parallel(grid_range);
  view = grid_r.view();
  double q_grid_r_1 = run_serial(grid_range), q_grid_r_all = run_parallel(grid_range);
  view = grid.view();
  double q_tree_1 = run_serial(tree_range), q_tree_all = run_parallel(tree_range);
  double q_knn_1 = run_serial(tree_knn), q_knn_all = run_parallel(tree_knn);
  // The grid functor ran 12 times over all queries (two grids), the kd-tree's 6 times.
  double mean_grid = double(found_grid.load()) / (12.0 * double(nq));
  double mean_tree = double(found_tree.load()) / (6.0 * double(nq));

  const double wall = now() - wall0;
  const double other = ((machine_busy_seconds() - busy0) - (own_cpu_seconds() - own0)) / wall;

  std::printf("mean photons per range query: grid %.2f, kd-tree %.2f\n", mean_grid, mean_tree);
  std::printf("CPU taken by other work during the run: %.2f of %d cores (wall %.1f s)\n", other, cores, wall);
  std::printf("stochastic grid: %zu of %zu photons kept (%.1f%%), %.2f bytes per input photon\n", sgrid.size(), n,
              100.0 * double(sgrid.size()) / double(n), double(sgrid.bytes()) / double(n));
  std::printf("\n| structure | build ms / M photons (1 thread) | build ms / M photons (%d threads) | range queries/s "
              "(1 thread) | range queries/s (%d threads) | kNN k=50 queries/s (1 thread) | kNN k=50 queries/s (%d "
              "threads) | bytes / photon |\n",
              cores, cores, cores);
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|\n");
  std::printf("| hash grid (cell 2r) | %.1f | %.1f | %.2f M | %.2f M | — | — | %.1f |\n", t_grid_1 * 1e3 * per_m,
              t_grid_all * 1e3 * per_m, nq / q_grid_1 * 1e-6, nq / q_grid_all * 1e-6,
              double(grid.bytes()) / double(n));
  std::printf("| hash grid (cell r) | — | %.1f | %.2f M | %.2f M | — | — | %.1f |\n", t_grid_r_all * 1e3 * per_m,
              nq / q_grid_r_1 * 1e-6, nq / q_grid_r_all * 1e-6, double(grid_r.bytes()) / double(n));
  std::printf("| stochastic hash grid (cell 2r) | — | %.1f | — | — | — | — | %.1f (per input photon) |\n",
              t_sgrid_all * 1e3 * per_m, double(sgrid.bytes()) / double(n));
  std::printf("| kd-tree (nanoflann 1.4.3) | %.1f | (serial) | %.2f M | %.2f M | %.2f M | %.2f M | %.1f |\n",
              t_tree * 1e3 * per_m, nq / q_tree_1 * 1e-6, nq / q_tree_all * 1e-6, nq / q_knn_1 * 1e-6,
              nq / q_knn_all * 1e-6, double(tree.bytes()) / double(n));
  std::printf("\nmachine: %s, %d cores\n", cpu_model().c_str(), cores);
  return 0;
}
