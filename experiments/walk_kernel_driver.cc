// The dying-ant lane walk of several revisions in one program (experiments/bench_walk_kernel.py).
//
// Built twice over: with -DJACO_ADAPTER once per revision, beside that revision's walk_lanes.cc and
// with its walk_lanes.h (so the colony's layout is that revision's), it gives the revision's walk a
// plain C entry point run_<JACO_ISA>; without it, it is the program that loads the inputs and walks
// every colony with each revision in turn, round after round, in alternating order.
#include <cstdint>

#ifdef JACO_ADAPTER
#include <algorithm>
#include <type_traits>
#include <utility>

#include "walk_lanes.h"
#define JACO_CAT2(a, b) a##b
#define JACO_CAT(a, b) JACO_CAT2(a, b)
// This revision's walk, built as walk_lanes_v<i>, of the type its header gives every set's walk.
decltype(walk_lanes_baseline) JACO_CAT(walk_lanes_, JACO_ISA);

// Revisions before 90eca43 read each move's place in the 3x3 neighbourhood from the colony.
template <typename C>
auto set_places(C& c, int) -> decltype(c.row_of[0], void()) {
  static const int32_t dr[8] = {-1, 0, 1, 0, -1, 1, 1, -1}, dc[8] = {0, 1, 0, -1, 1, 1, -1, -1};
  for (int k = 0; k < 8; ++k) c.row_of[k] = dr[k], c.col_of[k] = dc[k];
}
template <typename C>
void set_places(C&, long) {}
// Revisions with tabu planes: each ant its own bit, ceil(A / 32) planes of the group's cells, as
// walk.cc gives the benchmark's colonies.
template <typename C>
auto set_planes(C& c, int) -> decltype(c.tabu_planes, void()) {
  c.tabu_planes = int32_t((c.n_ants + 31) / 32);
}
template <typename C>
void set_planes(C&, long) {}

template <typename Walk>
void walk_group(Walk* walk, const LaneColony* c, int64_t n) {
  if constexpr (std::is_invocable_v<Walk*, const LaneColony*, int64_t>)
    walk(c, n);
  else
    for (int64_t j = 0; j < n; ++j) walk(c[j]);
}

// Every colony of the inputs: one at a time where the revision's walk takes one colony, in groups
// of `group` consecutive colonies where it takes a group (as walk.cc hands them out).
extern "C" void JACO_CAT(run_, JACO_ISA)(const float* weights, const int32_t* offsets, int32_t start, int32_t goal,
                                        int32_t N, const uint32_t* words, int64_t A, int64_t S, int64_t B,
                                        int32_t* edges, int32_t* n_steps, int32_t* n_diagonal, bool* arrived,
                                        bool* visited, uint32_t* tabu, int32_t width, int64_t group) {
  if (!std::is_invocable_v<decltype(walk_lanes_baseline), const LaneColony*, int64_t>) group = 1;
  LaneColony c[64];
  for (int64_t first = 0; first < B; first += group) {
    const int64_t n = std::min<int64_t>({group, B - first, 64});
    for (int64_t j = 0; j < n; ++j) {
      const int64_t b = first + j;
      c[j] = LaneColony{};
      c[j].weights = weights + b * N * 8, c[j].offsets = offsets, c[j].start = start, c[j].goal = goal;
      c[j].n_cells = N, c[j].q0 = 0.0f, c[j].k0 = words[2 * b], c[j].k1 = words[2 * b + 1], c[j].n_ants = A;
      c[j].steplimit = S, c[j].ant_begin = 0, c[j].ant_end = A, c[j].exploit = false, c[j].edges = edges + b * S * A;
      c[j].n_steps = n_steps + b * A, c[j].n_diagonal = n_diagonal + b * A, c[j].arrived = arrived + b * A;
      c[j].visited = visited + b * N, c[j].tabu = tabu, c[j].width = width;
      set_places(c[j], 0);
      set_planes(c[j], 0);
    }
    walk_group(JACO_CAT(walk_lanes_, JACO_ISA), c, n);
  }
}

#else
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <string>
#include <vector>

typedef void (*Run)(const float*, const int32_t*, int32_t, int32_t, int32_t, const uint32_t*, int64_t, int64_t,
                    int64_t, int32_t*, int32_t*, int32_t*, bool*, bool*, uint32_t*, int32_t, int64_t);
#define X(v)                                                                                                       \
  extern "C" void run_##v(const float*, const int32_t*, int32_t, int32_t, int32_t, const uint32_t*, int64_t,     \
                          int64_t, int64_t, int32_t*, int32_t*, int32_t*, bool*, bool*, uint32_t*, int32_t, int64_t);
VARIANTS
#undef X
#define X(v) run_##v,
const Run kRuns[] = {VARIANTS};
#undef X
constexpr int kN = sizeof(kRuns) / sizeof(kRuns[0]);

static double cpu_now() {  // this thread's CPU time: the walk runs on it alone
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return double(t.tv_sec) + 1e-9 * double(t.tv_nsec);
}

template <typename T>
static std::vector<T> read(const std::string& path, size_t n) {
  std::vector<T> out(n);
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f || std::fread(out.data(), sizeof(T), n, f) != n) {
    std::fprintf(stderr, "cannot read %s\n", path.c_str());
    std::exit(2);
  }
  std::fclose(f);
  return out;
}

int main(int argc, char** argv) {
  if (argc < 3) return 2;
  const std::string dir = argv[1];
  const int rounds = std::atoi(argv[2]);
  const int64_t group = argc > 3 ? std::atoll(argv[3]) : 8;  // colonies a group, where a revision takes groups
  const auto sizes = read<int64_t>(dir + "/sizes.bin", 6);  // colonies, cells, ants, step limit, start, goal
  const int64_t B = sizes[0], N = sizes[1], A = sizes[2], S = sizes[3];
  const auto offsets = read<int32_t>(dir + "/offsets.bin", 8);
  const auto words = read<uint32_t>(dir + "/words.bin", size_t(2 * B));
  const auto weights = read<float>(dir + "/weights.bin", size_t(B * N * 8));
  const int32_t width = offsets[5] - 1 >= 3 ? offsets[5] - 1 : 0;  // jaco.moves.MOVES on a grid (walk.cc)
  const int64_t pad = width + 2;
  struct Out {
    std::vector<int32_t> edges, n_steps, n_diagonal;
    std::vector<uint8_t> arrived, visited;
    std::vector<uint32_t> tabu;
  } out[kN];
  for (auto& o : out) {
    o.edges.resize(size_t(B * S * A)), o.n_steps.resize(size_t(B * A)), o.n_diagonal.resize(size_t(B * A));
    o.arrived.resize(size_t(B * A)), o.visited.resize(size_t(B * N)), o.tabu.assign(size_t((A + 31) / 32 * std::min<int64_t>(B, 64) * N + 2 * pad), 0u);
  }
  auto walk_all = [&](int v) {
    Out& o = out[v];
    kRuns[v](weights.data(), offsets.data(), int32_t(sizes[4]), int32_t(sizes[5]), int32_t(N), words.data(), A, S, B,
             o.edges.data(), o.n_steps.data(), o.n_diagonal.data(), reinterpret_cast<bool*>(o.arrived.data()),
             reinterpret_cast<bool*>(o.visited.data()), o.tabu.data() + pad, width, group);
  };
  for (int v = 0; v < kN; ++v) walk_all(v);
  int64_t steps = 0;
  for (int32_t n : out[0].n_steps) steps += n;
  for (int v = 1; v < kN; ++v)
    if (out[v].edges != out[0].edges || out[v].n_steps != out[0].n_steps || out[v].n_diagonal != out[0].n_diagonal ||
        out[v].arrived != out[0].arrived || out[v].visited != out[0].visited) {
      std::printf("DIFFER %d\n", v);
      return 1;
    }
  std::vector<std::vector<double>> t(kN), ratio(kN);
  for (int r = 0; r < rounds; ++r) {
    double d[kN];
    for (int i = 0; i < kN; ++i) {  // each round starts with the next revision: no revision always goes first
      const int v = (r + i) % kN;
      const double t0 = cpu_now();
      walk_all(v);
      d[v] = cpu_now() - t0;
      t[v].push_back(d[v]);
    }
    for (int v = 0; v < kN; ++v) ratio[v].push_back(d[v] / d[0]);
  }
  for (int v = 0; v < kN; ++v) {
    std::sort(t[v].begin(), t[v].end());
    std::sort(ratio[v].begin(), ratio[v].end());
    // RESULT variant median_s best_s steps ratio_to_first_median ratio_q25 ratio_q75
    std::printf("RESULT %d %.9f %.9f %lld %.5f %.5f %.5f\n", v, t[v][t[v].size() / 2], t[v][0], (long long)steps,
                ratio[v][ratio[v].size() / 2], ratio[v][ratio[v].size() / 4], ratio[v][3 * ratio[v].size() / 4]);
  }
  return 0;
}
#endif
