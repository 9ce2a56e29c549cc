// IACA's backtracking walk as an XLA FFI kernel for the CPU (jaco.planners.iaca.native_backtrack_walk):
// the same moves, pheromone and stacks bit for bit as jax_backtrack_walk in iaca.py (thesis ch. 4).
// One colony's walk is iaca_lanes.cc, built once per instruction set; this file runs the colonies
// of a call on XLA's threads with the set the dying-ant walk uses.
//
// The ants walk in lock-step: at step t every running ant reads the pheromone as the local
// updates of step t - 1 left it, then the cells entered at step t are updated (eqs. 4-2..4-4).
// Within a step the ants are independent, so when a call has fewer colonies than threads (one
// solve), a colony's ants are split into chunks that a team of threads takes at every step. Which
// thread walks an ant changes nothing: an ant's uniforms are its own (Threefry on ant and step) and
// a cell's update depends only on how many ants entered it, straight or diagonally.
#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "iaca_lanes.h"
#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

extern "C" int jaco_isa_get();  // walk.cc: the instruction set in use, an index of JACO_ISA_LIST

namespace {

#include "kernel_threads.h"

#ifdef JACO_HAVE_AVX2
constexpr const BacktrackKernel* kAvx2 = &backtrack_avx2;
#else
constexpr const BacktrackKernel* kAvx2 = nullptr;
#endif
#ifdef JACO_HAVE_AVX512
constexpr const BacktrackKernel* kAvx512 = &backtrack_avx512;
#else
constexpr const BacktrackKernel* kAvx512 = nullptr;
#endif
const BacktrackKernel* const kKernels[] = {&backtrack_baseline, kAvx2, kAvx512};  // JACO_ISA_LIST's order

const BacktrackKernel& kernel() {
  const int i = jaco_isa_get();  // only a set that was built and that this CPU runs
  return *(i >= 0 && i < 3 && kKernels[i] ? kKernels[i] : kKernels[0]);
}

// ---- a colony walked by a team of threads ----------------------------------------------------
// The colony's first thread (the leader) runs the steps: it publishes step t with chunk 0 taken,
// walks it, takes any chunk left like any other thread, waits until every chunk is done, then
// updates. The others join when they start and take chunks while there are any; after each chunk
// they prepare its ants for the next step while the leader updates, and the leader publishes the
// next step once they have. The leader never waits for a thread that has not joined (only for
// the chunks another thread took), so a busy pool costs speed, never a deadlock.
struct Team {
  // Written by the leader, read by the others: the step published, the chunks taken.
  alignas(64) std::atomic<uint64_t> ticket{~0ull};  // step << 32 | next chunk to take
  std::atomic<bool> finished{false};
  std::atomic<void*> colony{nullptr};
  int64_t n_chunks = 1;
  // Written by the others, read by the leader (a line of its own): of the chunks they took this
  // step, how many are walked, and how many prepared for the next step.
  alignas(64) std::atomic<int64_t> done{0};
  std::atomic<int64_t> prepared{0};
};

constexpr uint64_t kChunkBits = 0xFFFFFFFFull;

// A wait's spins-th turn: a pause at first, then the core given up now and then (a pool shared with
// other work, or more threads than cores: the thread awaited may have lost its core).
inline void wait_turn(int64_t spins) {
  if (spins < 4096) {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
  } else {
    std::this_thread::yield();
  }
}

// Take and walk chunks of the published step until none is left; how many. A thread other than
// the leader then prepares each chunk's ants for the next step while the leader updates (the
// leader waits for that before it publishes the next step).
int64_t take_chunks(Team& team, const BacktrackKernel& walk, void* colony, bool leader) {
  for (int64_t taken = 0;; ++taken) {
    const uint64_t seen = team.ticket.load(std::memory_order_acquire);
    if ((seen & kChunkBits) >= uint64_t(team.n_chunks)) return taken;
    const uint64_t got = team.ticket.fetch_add(1, std::memory_order_acq_rel);
    const uint64_t k = got & kChunkBits;
    if (k >= uint64_t(team.n_chunks)) return taken;
    const int64_t t = int64_t(got >> 32);
    walk.step_chunk(colony, int64_t(k), t);
    if (!leader) {
      team.done.fetch_add(1, std::memory_order_release);
      walk.prepare_chunk(colony, int64_t(k), t + 1);
      team.prepared.fetch_add(1, std::memory_order_release);
    }
  }
}

// A step with few ants walking is not worth the hand-over: the leader walks it alone.
constexpr int64_t kTeamAnts = 16;

void lead(Team& team, const BacktrackKernel& walk, void* colony, int64_t steplimit, int64_t n_ants) {
  team.colony.store(colony, std::memory_order_release);
  for (int64_t t = 0, walking = n_ants; t < steplimit && walking > 0; ++t) {
    int64_t lent = 0;  // chunks the others took
    if (walking < kTeamAnts) {
      for (int64_t k = 0; k < team.n_chunks; ++k) walk.step_chunk(colony, k, t);
    } else {
      team.done.store(0, std::memory_order_relaxed);
      team.prepared.store(0, std::memory_order_relaxed);
      team.ticket.store(uint64_t(t) << 32 | 1, std::memory_order_release);  // chunk 0 is the leader's
      walk.step_chunk(colony, 0, t);
      lent = team.n_chunks - 1 - take_chunks(team, walk, colony, true);
      for (int64_t spins = 0; team.done.load(std::memory_order_acquire) < lent; ++spins) wait_turn(spins);
    }
    walking = walk.update(colony);
    for (int64_t spins = 0; team.prepared.load(std::memory_order_acquire) < lent; ++spins) wait_turn(spins);
  }
  team.finished.store(true, std::memory_order_release);
}

void follow(Team& team, const BacktrackKernel& walk) {
  int64_t idle = 0;
  while (!team.finished.load(std::memory_order_acquire)) {
    void* colony = team.colony.load(std::memory_order_acquire);
    const uint64_t seen = team.ticket.load(std::memory_order_acquire);
    if (colony && seen != ~0ull && (seen & kChunkBits) < uint64_t(team.n_chunks)) {
      take_chunks(team, walk, colony, false);
      idle = 0;
    } else {
      wait_turn(idle++);
    }
  }
}

ffi::Error BacktrackImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> tau_in, ffi::Buffer<ffi::F32> rows,
                         ffi::Buffer<ffi::F32> factors, ffi::Buffer<ffi::U32> words, ffi::Buffer<ffi::S32> start, ffi::Buffer<ffi::S32> goal,
                         ffi::Buffer<ffi::F32> scalars, ffi::Buffer<ffi::S32> offsets, ffi::Buffer<ffi::S32> tables,
                         ffi::ResultBuffer<ffi::F32> tau_out, ffi::ResultBuffer<ffi::S32> stack_out,
                         ffi::ResultBuffer<ffi::S32> sp_out, ffi::ResultBuffer<ffi::PRED> arrived_out,
                         ffi::ResultBuffer<ffi::S32> actions_out, ffi::ResultBuffer<ffi::PRED> visited_out,
                         ffi::ResultBuffer<ffi::PRED> infeasible_out, ffi::ResultBuffer<ffi::S32> moves_out,
                         int64_t steplimit, bool exploit, bool table) {
  const auto rd = rows.dimensions();
  const auto sd = stack_out->dimensions();
  const int64_t N = rd[rd.size() - 2], A = sd[sd.size() - 2], D = sd[sd.size() - 1];
  const int64_t B = leading(rd, 2);
  const int64_t n_tables = tables.dimensions()[tables.dimensions().size() - 1];
  const BacktrackKernel& walk = kernel();
  // Fewer colonies than threads: a team of threads per colony, one chunk of its ants a thread
  // (taken by another thread when its own has not come; more chunks cost more hand-overs a step).
  const int64_t n_threads = std::max<int64_t>(pool.num_threads(), 1);
  const int64_t parts = B > 0 && B < n_threads ? std::min<int64_t>((n_threads + B - 1) / B, std::max<int64_t>(A / 16, 1)) : 1;
  const int64_t n_chunks = parts;
  auto colony_of = [&](int64_t b) {
    const BacktrackInputs in{tau_in.typed_data() + b * N, rows.typed_data() + b * N * 8, table ? factors.typed_data() + b * N * 8 : nullptr,
                    scalars.typed_data() + b * 7, offsets.typed_data() + b * 8, tables.typed_data() + b * n_tables,
                    words.typed_data()[2 * b], words.typed_data()[2 * b + 1], start.typed_data()[b], goal.typed_data()[b]};
    const BacktrackOutputs out{tau_out->typed_data() + b * N, stack_out->typed_data() + b * A * D, sp_out->typed_data() + b * A,
                      actions_out->typed_data() + b * A, moves_out->typed_data() + b * A * D, arrived_out->typed_data() + b * A,
                      visited_out->typed_data() + b * N, infeasible_out->typed_data() + b * N};
    return walk.make(in, out, BacktrackSizes{N, A, D, steplimit, n_chunks, exploit, table});
  };
  std::vector<Team> teams(parts > 1 ? B : 0);
  for (Team& team : teams) team.n_chunks = n_chunks;
  for_each_colony(pool, B * parts, [&]() {
    return [&](int64_t task) {
      const int64_t b = task / parts;
      if (parts > 1 && task % parts) return follow(teams[b], walk);
      void* colony = colony_of(b);
      if (parts > 1) {
        lead(teams[b], walk, colony, steplimit, A);
      } else {
        for (int64_t t = 0, walking = A; t < steplimit && walking > 0; ++t) {
          walk.step_chunk(colony, 0, t);
          walking = walk.update(colony);
        }
      }
      walk.finish(colony);
    };
  });
  return ffi::Error::Success();
}

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoBacktrack, BacktrackImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // tau (..., N)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // detour rows (..., N, 8)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // weight factors (..., N, 8) with table, else unread
                                  .Arg<ffi::Buffer<ffi::U32>>()   // key words (..., 2)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // start (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // goal (...)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // q0, alpha, beta, lo, hi, rho_local, q (..., 7)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move offsets (..., 8)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // power tables (..., 2·1025)
                                  .Ret<ffi::Buffer<ffi::F32>>()   // tau (..., N)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // stack (..., A, D)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // sp (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // arrived (..., A)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // actions (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // visited (..., N)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // infeasible (..., N)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // moves (..., A, D)
                                  .Attr<int64_t>("steplimit")
                                  .Attr<bool>("exploit")
                                  .Attr<bool>("table"));
