// The dying-ant walk of jaco as an XLA FFI kernel for the CPU, the choice of its lane kernels'
// instruction set, and the stop flag of interrupted runs. The other kernels sit next to the code
// they serve, in the same library: jaco/planners/iaca.cc (IACA's backtracking walk),
// jaco/engine/pheromone.cc (the deposit), jaco/engine/local_search.cc (the octile shortcut) and
// jaco/potential.cc (the APF's next cell).
//
// The JAX walk defines what an ant does (jaco/engine/walk.py: jax_walk); this kernel takes the
// same moves bit for bit. Every float operation below
// is one the JAX walk performs in the same order on the same float32 values: sums added left to
// right, no fused multiply-add (built with -ffp-contract=off), powers by the integer tables of
// jaco/engine/bitexact.py. The uniforms are counter-based (Threefry-2x32 on (ant, step / 2)), so nothing
// depends on how ants are spread over threads.
//
// Leading (batch) dimensions of every argument are colonies: vmap, sweeps and seeds all become
// one call, whose colonies are split over the threads of XLA's intra-op pool.

#include <algorithm>
#include <atomic>
#include <cmath>
#include <climits>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

#include "walk_lanes.h"
#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

namespace {

#include "kernel_threads.h"
#include "walk_shared.h"

// ---- the instruction set of the lane kernels (walk_lanes.cc) -----------------------------------
// Each instruction set that setup.py built is used only where this CPU has it: the widest such one
// by default, another by jaco_isa_set (jaco.engine.native.set_isa, JACO_NATIVE_ISA). Every set
// takes the same moves, so the choice changes speed alone.
using LaneWalk = void (*)(const LaneColony*, int64_t);

bool cpu_has(const char* isa) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (!std::strcmp(isa, "avx2"))
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") && __builtin_cpu_supports("bmi2") &&
           __builtin_cpu_supports("popcnt");
  if (!std::strcmp(isa, "avx512"))
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vl") && __builtin_cpu_supports("avx512dq") && cpu_has("avx2");
#endif
  return !std::strcmp(isa, "baseline");
}

struct Isa {
  const char* name;
  LaneWalk walk;
};

#ifdef JACO_HAVE_AVX2
constexpr LaneWalk kAvx2 = walk_lanes_avx2;
#else
constexpr LaneWalk kAvx2 = nullptr;  // not built (a compiler or CPU family without it)
#endif
#ifdef JACO_HAVE_AVX512
constexpr LaneWalk kAvx512 = walk_lanes_avx512;
#else
constexpr LaneWalk kAvx512 = nullptr;
#endif
const Isa kIsas[] = {{"baseline", walk_lanes_baseline}, {"avx2", kAvx2}, {"avx512", kAvx512}};
constexpr int kNIsas = int(sizeof kIsas / sizeof kIsas[0]);

bool isa_runs(int i) { return i >= 0 && i < kNIsas && kIsas[i].walk && cpu_has(kIsas[i].name); }

int widest_isa() {
  int best = 0;
  for (int i = 0; i < kNIsas; ++i)
    if (isa_runs(i)) best = i;
  return best;
}

std::atomic<int> current_isa{-1};

LaneWalk lane_walk() {
  int i = current_isa.load(std::memory_order_relaxed);
  if (i < 0) current_isa.store(i = widest_isa(), std::memory_order_relaxed);
  return kIsas[i].walk;
}

// The width w of the grid whose moves the offsets are, in jaco.moves.MOVES's order (move k is
// dr[k]·w + dc[k]), when w >= 3; else 0.
int32_t grid_width(const int32_t* off) {
  static const int32_t dr[8] = {-1, 0, 1, 0, -1, 1, 1, -1}, dc[8] = {0, 1, 0, -1, 1, 1, -1, -1};
  if (off[5] < 4) return 0;
  const int32_t w = off[5] - 1;
  for (int k = 0; k < 8; ++k)
    if (off[k] != dr[k] * w + dc[k]) return 0;
  return w;
}

// ---- the dying-ant walk (jaco.engine.walk.jax_walk) ------------------------------------------
// The fewest ants a part of a split colony gets (and a part at least N / 16, N the cells). Measured
// on one solve (2-core AMD EPYC, 20 iterations, alternating): 50 or 100 ants on a 30x30 map ran
// 1.2-1.3x slower split in two parts of at least 16 ants than not split, 200 ants 1.06x faster,
// 800 ants 1.4x faster; 200 ants on 128x128 ran 1.18x slower split, 400 on 64x64 the same.
constexpr int64_t kPartAnts = 100;

// Colonies in a group of the lane walk: up to 8 (the lanes then idle at the end of every 8
// colonies' walks instead of every colony's), fewer where the call has few colonies for its
// threads (at least 4 groups a thread, so that they share the work out evenly), and few enough
// that the group's step slots (S·A a colony) and weight elements (8N) have 32-bit indices.
int64_t group_size(int64_t colonies, int64_t threads, int64_t cells, int64_t slots) {
  const int64_t limit = int64_t(INT32_MAX) / std::max<int64_t>({8 * cells, slots, 1});
  return std::max<int64_t>(1, std::min<int64_t>({8, colonies / (4 * threads), limit}));
}

// How the lane walk keeps its tabu lists (walk_lanes.h): -1 its choice (tabu_planes), 0 a bit a
// lane, 1 tabu planes wherever they fit (jaco.engine.native.set_tabu, for tests and measurements;
// every choice takes the same moves).
std::atomic<int32_t> tabu_choice{-1};
// Tabu planes for a group of `colonies` colony parts of `ants` ants on `cells` cells: each ant its
// own bit, so that an ant that stops clears nothing and no step stores its cell visited; one scan
// of the planes after the walk does both. They pay while a colony's planes are small against the
// steps its ants take (one solve on the benchmark's 30x30 map 0.93-0.96 of the time; on 48x48 to
// 128x128 random maps, where the ants die within about 20 steps, 1.02-1.11: docs/native.md). 0: a
// bit a lane.
constexpr int64_t kPlaneWords = 4096;                      // a colony's planes (16 KiB)
constexpr int64_t kPlaneWordsForced = int64_t(1) << 22;    // a group's, where tests force planes (16 MiB)
int32_t tabu_planes(int32_t choice, int64_t cells, int64_t ants, int64_t colonies) {
  const int64_t planes = (ants + 31) / 32;
  const bool fit = choice == 1 ? planes * cells * colonies <= kPlaneWordsForced : planes * cells <= kPlaneWords;
  return choice != 0 && fit ? int32_t(planes) : 0;
}

ffi::Error WalkImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> weights, ffi::Buffer<ffi::U32> words,
                    ffi::Buffer<ffi::S32> start, ffi::Buffer<ffi::S32> goal, ffi::Buffer<ffi::F32> q0,
                    ffi::Buffer<ffi::S32> offsets, ffi::Buffer<ffi::S32> previous, ffi::ResultBuffer<ffi::S32> edges,
                    ffi::ResultBuffer<ffi::S32> n_steps,
                    ffi::ResultBuffer<ffi::S32> n_diagonal, ffi::ResultBuffer<ffi::PRED> arrived,
                    ffi::ResultBuffer<ffi::PRED> visited, int64_t steplimit, bool exploit) {
  const auto wd = weights.dimensions();
  const auto md = edges->dimensions();
  const int64_t N = wd[wd.size() - 2], S = md[md.size() - 2], A = md[md.size() - 1];
  const int64_t B = leading(wd, 2);
  const float* W0 = weights.typed_data();
  const uint32_t* K = words.typed_data();
  const int32_t *st = start.typed_data(), *gl = goal.typed_data(), *off0 = offsets.typed_data();
  const float* q = q0.typed_data();
  int32_t* ed0 = edges->typed_data();
  // The steps are written over the last walks' (each column: steps, then 8N), and only the rows
  // those used are cleared (walk_lanes.cc, clear_columns). XLA hands the buffer over in place
  // (input_output_aliases); a copy where it did not.
  if (previous.typed_data() != ed0) std::memcpy(ed0, previous.typed_data(), previous.size_bytes());
  int32_t *ns0 = n_steps->typed_data(), *nd0 = n_diagonal->typed_data();
  bool *arr0 = arrived->typed_data(), *vis0 = visited->typed_data();
  const LaneWalk walk = lane_walk();
  (void)steplimit;  // S, the step buffer's length
  // Fewer colonies than threads (one solve of a large colony): each colony's ants are split
  // between threads. An ant's walk depends on nothing but its own uniforms, so the moves are the
  // same however split; each part marks the cells its ants visited in its own row, merged below.
  // A part costs a hand-over to another core, which then reads the weights table (32 bytes a
  // cell) from the first: it pays only with many ants a cell (kPartAnts).
  const int64_t n_threads = std::max<int64_t>(pool.num_threads(), 1);
  const int64_t part_ants = std::max<int64_t>(kPartAnts, N / 16);
  const int64_t parts = B > 0 && B < n_threads ? std::min<int64_t>((n_threads + B - 1) / B, std::max<int64_t>(A / part_ants, 1)) : 1;
  std::vector<uint8_t> part_visited(parts > 1 ? B * parts * N : 0);
  // Unsplit colonies are walked in groups of consecutive colonies, each group in one pool of lanes
  // (walk_lanes.h): a colony's last ants then walk beside the next colony's first, where alone
  // they left most lanes idle. The colonies of a call share one map shape, so their move offsets
  // are the same; where a caller passed others, each colony is walked on its own.
  bool same_offsets = true;
  for (int64_t b = 1; b < B; ++b) same_offsets &= std::memcmp(off0 + b * 8, off0, 8 * sizeof(int32_t)) == 0;
  const int64_t per_group = parts > 1 || !same_offsets ? 1 : group_size(B, n_threads, N, S * A);
  const int64_t tasks = parts > 1 ? B * parts : (B + per_group - 1) / per_group;
  const int32_t planes = tabu_planes(tabu_choice.load(), N, (A + parts - 1) / parts, per_group);

  for_each_colony(pool, tasks, [=, &part_visited]() {
    return [=, &part_visited, tabu = std::vector<uint32_t>(), group = std::vector<LaneColony>()](int64_t task) mutable {
      const int64_t first = parts > 1 ? task / parts : task * per_group, p = parts > 1 ? task % parts : 0;
      const int32_t width = grid_width(off0 + first * 8);
      group.clear();
      for (int64_t b = first; b < std::min(first + per_group, B); ++b) {
        bool* vis = parts > 1 ? reinterpret_cast<bool*>(part_visited.data() + task * N) : vis0 + b * N;
        group.push_back(LaneColony{W0 + b * N * 8, off0 + b * 8, st[b], gl[b], int32_t(N), q[b], K[2 * b],
                                   K[2 * b + 1], A, S, A * p / parts, A * (p + 1) / parts, exploit, ed0 + b * S * A,
                                   ns0 + b * A, nd0 + b * A, arr0 + b * A, vis, nullptr, planes, width});
      }
      const int64_t pad = int64_t(width) + 2, cells = std::max<int32_t>(planes, 1) * int64_t(group.size()) * N;
      if (int64_t(tabu.size()) < cells + 2 * pad) tabu.assign(cells + 2 * pad, 0u);  // zero between groups
      for (LaneColony& colony : group) colony.tabu = tabu.data() + pad;
      walk(group.data(), int64_t(group.size()));
    };
  });
  for (int64_t b = 0; b < B && parts > 1; ++b)
    for (int64_t i = 0; i < N; ++i) {
      bool any = false;
      for (int64_t p = 0; p < parts; ++p) any |= part_visited[(b * parts + p) * N + i] != 0;
      vis0[b * N + i] = any;
    }
  return ffi::Error::Success();
}

// ---- test entry points: the uniforms and the powers on their own ---------------------------
ffi::Error UniformsImpl(ffi::Buffer<ffi::U32> words, ffi::Buffer<ffi::U32> ants, ffi::Buffer<ffi::U32> steps,
                        ffi::ResultBuffer<ffi::F32> out) {
  const uint32_t* k = words.typed_data();
  for (int64_t i = 0; i < int64_t(ants.element_count()); ++i) {
    AntRng rng{k[0], k[1], ants.typed_data()[i]};
    out->typed_data()[i] = rng.at(steps.typed_data()[i]);
  }
  return ffi::Error::Success();
}

ffi::Error PowerImpl(ffi::Buffer<ffi::F32> x, ffi::Buffer<ffi::F32> a, ffi::Buffer<ffi::S32> tables,
                     ffi::ResultBuffer<ffi::F32> out) {
  for (int64_t i = 0; i < int64_t(x.element_count()); ++i)
    out->typed_data()[i] = table_power(x.typed_data()[i], a.typed_data()[i], tables.typed_data());
  return ffi::Error::Success();
}

// ---- the stop request: a compiled run's iteration loop ends when it is set -----------------------
// Set from Python when the user interrupts a call (jaco.progress.run_interruptibly); read once per
// iteration, so an interrupted run stops within one iteration and uses no CPU after.
std::atomic<int32_t> stop_requested{0};
// The most iterations a run has finished since Python last reset it: the iteration the loop asks
// about is the number finished, so the host reads a run's progress without a callback (a host
// callback costs about 100 µs; jaco.progress polls this instead).
std::atomic<int32_t> iterations_done{0};

ffi::Error StoppedImpl(ffi::Buffer<ffi::S32> iteration, ffi::ResultBuffer<ffi::PRED> out) {
  const int32_t t = iteration.typed_data()[0];
  int32_t seen = iterations_done.load(std::memory_order_relaxed);
  while (t > seen && !iterations_done.compare_exchange_weak(seen, t, std::memory_order_relaxed)) {
  }
  out->typed_data()[0] = stop_requested.load(std::memory_order_relaxed) != 0;
  return ffi::Error::Success();
}

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoStopped, StoppedImpl,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::Buffer<ffi::S32>>()    // the iteration
                                  .Ret<ffi::Buffer<ffi::PRED>>());  // whether to stop

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoWalk, WalkImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // weights (..., N, 8)
                                  .Arg<ffi::Buffer<ffi::U32>>()   // key words (..., 2)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // start (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // goal (...)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // q0 (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move offsets (..., 8)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // the last walks' edges (..., S, A), aliased to:
                                  .Ret<ffi::Buffer<ffi::S32>>()   // edges (..., S, A): from·8 + move, 8N where none
                                  .Ret<ffi::Buffer<ffi::S32>>()   // steps (..., A)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // diagonal steps (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // arrived (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // visited (..., N)
                                  .Attr<int64_t>("steplimit")
                                  .Attr<bool>("exploit"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoUniforms, UniformsImpl,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::Buffer<ffi::U32>>()
                                  .Arg<ffi::Buffer<ffi::U32>>()
                                  .Arg<ffi::Buffer<ffi::U32>>()
                                  .Ret<ffi::Buffer<ffi::F32>>());

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoPower, PowerImpl,
                              ffi::Ffi::Bind()
                                  .Arg<ffi::Buffer<ffi::F32>>()
                                  .Arg<ffi::Buffer<ffi::F32>>()
                                  .Arg<ffi::Buffer<ffi::S32>>()
                                  .Ret<ffi::Buffer<ffi::F32>>());

// ---- the instruction set, from Python (jaco.engine.native.isas / set_isa) -------------------------
extern "C" {
__attribute__((visibility("default"))) int jaco_isa_count() { return kNIsas; }
__attribute__((visibility("default"))) const char* jaco_isa_name(int i) {
  return i >= 0 && i < kNIsas ? kIsas[i].name : "";
}
__attribute__((visibility("default"))) int jaco_isa_built(int i) { return i >= 0 && i < kNIsas && kIsas[i].walk; }
__attribute__((visibility("default"))) int jaco_isa_runs(int i) { return isa_runs(i); }
__attribute__((visibility("default"))) int jaco_isa_get() {
  lane_walk();
  return current_isa.load();
}
__attribute__((visibility("default"))) void jaco_stop_set(int on) { stop_requested.store(on != 0); }
// The iterations finished (see iterations_done), set back to 0 when `reset`.
__attribute__((visibility("default"))) int jaco_iterations_done(int reset) {
  return reset ? iterations_done.exchange(0) : iterations_done.load();
}
// The lane walk's tabu lists (tabu_choice): -1 its choice, 0 a bit a lane, 1 tabu planes.
__attribute__((visibility("default"))) int jaco_tabu_get() { return tabu_choice.load(); }
__attribute__((visibility("default"))) int jaco_tabu_set(int choice) {
  if (choice < -1 || choice > 1) return -1;
  tabu_choice.store(choice);
  return 0;
}
// -1: the widest set this CPU runs; another set is taken only where it was built and the CPU runs it.
__attribute__((visibility("default"))) int jaco_isa_set(int i) {
  if (i == -1) i = widest_isa();
  if (!isa_runs(i)) return -1;
  current_isa.store(i);
  return 0;
}
}
