// The ant walks of jaco as XLA FFI kernels for the CPU.
//
// The JAX walks define what an ant does (jaco/engine/walk.py: jax_walk; jaco/planners/iaca.py:
// jax_backtrack_walk); these kernels take the same moves bit for bit. Every float operation below
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

#include "walk_shared.h"


// ---- running colonies on the intra-op threads ------------------------------------------------
// Colonies are taken in turn by the calling thread and the pool's threads. State is shared
// through a shared_ptr so that a task that starts after all colonies are done finds nothing to do.
template <typename PerThread>
void for_each_colony(ffi::ThreadPool& pool, int64_t n_colonies, PerThread make_worker) {
  const int64_t n_threads = std::min<int64_t>(std::max<int64_t>(pool.num_threads(), 1), n_colonies);
  if (n_threads <= 1) {
    auto worker = make_worker();
    for (int64_t b = 0; b < n_colonies; ++b) worker(b);
    return;
  }
  struct Shared {
    std::atomic<int64_t> next{0}, done{0};
    std::mutex m;
    std::condition_variable cv;
  };
  auto sh = std::make_shared<Shared>();
  auto task = [sh, n_colonies, make_worker]() {
    auto worker = make_worker();
    int64_t mine = 0;
    for (int64_t b; (b = sh->next.fetch_add(1)) < n_colonies; ++mine) worker(b);
    if (mine && sh->done.fetch_add(mine) + mine == n_colonies) {
      std::lock_guard<std::mutex> lock(sh->m);
      sh->cv.notify_all();
    }
  };
  for (int64_t i = 1; i < n_threads; ++i) {
    auto copy = task;
    pool.Schedule(std::move(copy));
  }
  task();
  std::unique_lock<std::mutex> lock(sh->m);
  sh->cv.wait(lock, [&] { return sh->done.load() == n_colonies; });
}

int64_t leading(const ffi::AnyBuffer::Dimensions& dims, int trailing) {
  int64_t n = 1;
  for (size_t i = 0; i + trailing < dims.size(); ++i) n *= dims[i];
  return n;
}

// ---- the instruction set of the lane kernels (walk_lanes.cc) -----------------------------------
// Each instruction set that setup.py built is used only where this CPU has it: the widest such one
// by default, another by jaco_isa_set (jaco.engine.native.set_isa, JACO_NATIVE_ISA). Every set
// takes the same moves, so the choice changes speed alone.
using LaneWalk = void (*)(const LaneColony&);

bool cpu_has(const char* isa) {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_cpu_init();
  if (!std::strcmp(isa, "avx2"))
    return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("popcnt");
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

// The width w of the grid whose 8 moves the offsets are (each r·w + c with (r, c) in {-1, 0, 1}^2,
// all 8 different and none (0, 0)), when w >= 3, with each move's (r, c) in row_of, col_of; else 0.
int32_t grid_width(const int32_t* off, int32_t* row_of, int32_t* col_of) {
  const int32_t w = *std::max_element(off, off + 8) - 1;
  if (w < 3) return 0;
  bool seen[9] = {};
  for (int k = 0; k < 8; ++k) {
    const int32_t r = (off[k] + w + 1) / w - 1, c = off[k] - r * w;  // off in [-w-1, w+1]
    if (off[k] < -w - 1 || r < -1 || r > 1 || c < -1 || c > 1 || (r == 0 && c == 0) || seen[3 * r + c + 4]) return 0;
    seen[3 * r + c + 4] = true;
    row_of[k] = r;
    col_of[k] = c;
  }
  return w;
}

// ---- the dying-ant walk (jaco.engine.walk.jax_walk) ------------------------------------------
ffi::Error WalkImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> weights, ffi::Buffer<ffi::U32> words,
                    ffi::Buffer<ffi::S32> start, ffi::Buffer<ffi::S32> goal, ffi::Buffer<ffi::F32> q0,
                    ffi::Buffer<ffi::S32> offsets, ffi::ResultBuffer<ffi::S8> moves,
                    ffi::ResultBuffer<ffi::S32> cells, ffi::ResultBuffer<ffi::S32> n_steps,
                    ffi::ResultBuffer<ffi::S32> n_diagonal, ffi::ResultBuffer<ffi::PRED> arrived,
                    ffi::ResultBuffer<ffi::PRED> visited, int64_t steplimit, bool exploit) {
  const auto wd = weights.dimensions();
  const auto md = moves->dimensions();
  const int64_t N = wd[wd.size() - 2], S = md[md.size() - 2], A = md[md.size() - 1];
  const int64_t B = leading(wd, 2);
  const float* W0 = weights.typed_data();
  const uint32_t* K = words.typed_data();
  const int32_t *st = start.typed_data(), *gl = goal.typed_data(), *off0 = offsets.typed_data();
  const float* q = q0.typed_data();
  int8_t* mv0 = moves->typed_data();
  int32_t* cl0 = cells->typed_data();
  int32_t *ns0 = n_steps->typed_data(), *nd0 = n_diagonal->typed_data();
  bool *arr0 = arrived->typed_data(), *vis0 = visited->typed_data();
  const LaneWalk walk = lane_walk();
  (void)steplimit;  // S, the step buffer's length

  for_each_colony(pool, B, [=]() {
    return [=, tabu = std::vector<uint32_t>()](int64_t b) mutable {
      LaneColony colony{W0 + b * N * 8, off0 + b * 8, st[b], gl[b], int32_t(N), q[b], K[2 * b], K[2 * b + 1],
                        A, S, exploit, mv0 + b * S * A, cl0 + b * S * A, ns0 + b * A, nd0 + b * A, arr0 + b * A,
                        vis0 + b * N, nullptr, 0, {}, {}};
      colony.width = grid_width(colony.offsets, colony.row_of, colony.col_of);
      const int64_t pad = int64_t(colony.width) + 2;
      if (int64_t(tabu.size()) < N + 2 * pad) tabu.assign(N + 2 * pad, 0u);  // zero between colonies
      colony.tabu = tabu.data() + pad;
      walk(colony);
    };
  });
  return ffi::Error::Success();
}

// ---- IACA's backtracking walk (jaco.planners.iaca.jax_backtrack_walk) -------------------------------
constexpr float kSqrt2 = static_cast<float>(1.4142135623730951);  // float32(hypot(1, 1))

inline float int_power(float x, int32_t k) {
  float out = 1.0f, base = x;
  for (int bit = 0; bit < 16; ++bit) {
    if ((k >> bit) & 1) out = out * base;
    base = base * base;
  }
  return out;
}

ffi::Error BacktrackImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> tau_in, ffi::Buffer<ffi::F32> rows,
                         ffi::Buffer<ffi::F32> factors, ffi::Buffer<ffi::U32> words, ffi::Buffer<ffi::S32> start, ffi::Buffer<ffi::S32> goal,
                         ffi::Buffer<ffi::F32> scalars, ffi::Buffer<ffi::S32> offsets, ffi::Buffer<ffi::S32> tables,
                         ffi::ResultBuffer<ffi::F32> tau_out, ffi::ResultBuffer<ffi::S32> stack_out,
                         ffi::ResultBuffer<ffi::S32> sp_out, ffi::ResultBuffer<ffi::PRED> arrived_out,
                         ffi::ResultBuffer<ffi::S32> actions_out, ffi::ResultBuffer<ffi::PRED> visited_out,
                         ffi::ResultBuffer<ffi::PRED> infeasible_out, int64_t steplimit, bool exploit, bool table) {
  const auto rd = rows.dimensions();
  const auto sd = stack_out->dimensions();
  const int64_t N = rd[rd.size() - 2], A = sd[sd.size() - 2], D = sd[sd.size() - 1];
  const int64_t B = leading(rd, 2);
  const int64_t n_tables = tables.dimensions()[tables.dimensions().size() - 1];
  const float *T0 = tau_in.typed_data(), *R0 = rows.typed_data(), *F0 = factors.typed_data(), *P0 = scalars.typed_data();
  const uint32_t* K = words.typed_data();
  const int32_t *st = start.typed_data(), *gl = goal.typed_data(), *off0 = offsets.typed_data();
  const int32_t* tab0 = tables.typed_data();
  float* tau0 = tau_out->typed_data();
  int32_t *stk0 = stack_out->typed_data(), *sp0 = sp_out->typed_data(), *act0 = actions_out->typed_data();
  bool *arr0 = arrived_out->typed_data(), *vis0 = visited_out->typed_data(), *bad0 = infeasible_out->typed_data();

  for_each_colony(pool, B, [=]() {
    struct Scratch {
      std::vector<uint8_t> tabu;           // (A, N): cells each ant entered
      std::vector<int32_t> cur, entered;   // entered: (A, D) cells in the order entered, start first
      std::vector<int32_t> n_entered, n1, n2, touched, mark;
      std::vector<uint8_t> running, good;
      std::vector<AntRng> rng;
    };
    return [=, s = std::make_shared<Scratch>()](int64_t b) {
      const float* R = R0 + b * N * 8;
      const float* F = F0 + b * N * 8;
      const float* P = P0 + b * 7;
      const float q0 = P[0], alpha = P[1], beta = P[2], lo = P[3], hi = P[4], rho = P[5], q = P[6];
      const int32_t* off = off0 + b * 8;
      const int32_t* tab = tab0 + b * n_tables;
      const int32_t start_b = st[b], goal_b = gl[b];
      float* tau = tau0 + b * N;
      int32_t* stack = stk0 + b * A * D;
      int32_t* sp = sp0 + b * A;
      int32_t* actions = act0 + b * A;
      bool* arrived = arr0 + b * A;
      bool* vis = vis0 + b * N;
      bool* bad = bad0 + b * N;
      std::memcpy(tau, T0 + b * N, N * sizeof(float));
      s->tabu.assign(A * N, 0);
      s->cur.assign(A, start_b);
      s->entered.assign(A * D, 0);
      s->n_entered.assign(A, 1);
      s->n1.assign(N, 0);
      s->n2.assign(N, 0);
      s->running.assign(A, start_b != goal_b);
      s->rng.clear();
      for (int64_t a = 0; a < A; ++a) {
        s->rng.push_back(AntRng{K[2 * b], K[2 * b + 1], uint32_t(a)});
        s->tabu[a * N + start_b] = 1;
        s->entered[a * D] = start_b;
        stack[a * D] = start_b;
        sp[a] = 0;
        actions[a] = 0;
      }
      const float keep = 1.0f - rho;
      const float amount[2] = {q / 1.0f, q / kSqrt2};
      for (int64_t t = 0; t < steplimit; ++t) {
        bool any_running = false;
        s->touched.clear();
        for (int64_t a = 0; a < A; ++a) {
          if (!s->running[a]) continue;
          any_running = true;
          uint8_t* tabu = s->tabu.data() + a * N;
          const int32_t c = s->cur[a];
          const float* r = R + int64_t(c) * 8;
          bool allowed[8];
          int n_allowed = 0;
          float rr[8], total = 0.0f;
          for (int k = 0; k < 8; ++k) {
            allowed[k] = r[k] > 0.0f && !tabu[c + off[k]];
            n_allowed += allowed[k];
            rr[k] = allowed[k] ? r[k] : 0.0f;
          }
          if (n_allowed == 0) {
            if (sp[a] > 0) {  // step back along the path; the dead end stays tabu
              s->cur[a] = stack[a * D + sp[a] - 1];
              sp[a] -= 1;
              actions[a] += 1;
            } else {
              s->running[a] = 0;  // back at the start with nothing left: dead
            }
            continue;
          }
          total = rr[0];
          for (int k = 1; k < 8; ++k) total = total + rr[k];
          float w[8];
          for (int k = 0; k < 8; ++k) {
            if (!allowed[k]) {
              w[k] = 0.0f;
              continue;
            }
            float v;
            if (table) {  // another planner's factor, fixed for the iteration
              v = table_power(tau[c + off[k]], alpha, tab) * F[int64_t(c) * 8 + k];
            } else {  // eq. 4-5 over the ant's allowed moves
              float eta = n_allowed == 1 ? 1.0f : 1.0f - rr[k] / std::max(total, 1e-12f);
              eta = std::max(eta, 1e-6f);
              v = table_power(tau[c + off[k]], alpha, tab) * table_power(eta, beta, tab);
            }
            if (std::isnan(v)) v = 1e-30f;
            w[k] = std::min(std::max(v, 1e-30f), 1e30f);
          }
          const int k = choose(w, s->rng[a].at(uint32_t(t)), q0, exploit);
          const int32_t next = c + off[k];
          s->cur[a] = next;
          sp[a] += 1;
          stack[a * D + sp[a]] = next;
          tabu[next] = 1;
          s->entered[a * D + s->n_entered[a]++] = next;
          actions[a] += 1;
          if (s->n1[next] + s->n2[next] == 0) s->touched.push_back(next);
          (k < 4 ? s->n1 : s->n2)[next] += 1;
          s->running[a] = next != goal_b;
        }
        if (!any_running) break;
        for (int32_t cell : s->touched) {  // eqs. 4-2..4-4 (jaco.planners.iaca.local_update)
          const int32_t n1 = s->n1[cell], n2 = s->n2[cell], k = n1 + n2;
          const float deposit = float(n1) * amount[0] + float(n2) * amount[1];
          const float decay = int_power(keep, k);
          const float mean_decay = rho > 1e-6f ? (1.0f - decay) / std::max(float(k) * rho, 1e-12f) : 1.0f;
          const float v = decay * tau[cell] + deposit * mean_decay;
          tau[cell] = std::min(std::max(v, lo), hi);
          s->n1[cell] = s->n2[cell] = 0;
        }
      }
      // Final paths, visited cells and the cells of eq. (4-6) (jaco.planners.iaca.infeasible_cells).
      std::memset(vis, 0, N);
      std::memset(bad, 0, N);
      s->good.assign(N, 0);
      s->mark.assign(N, -1);
      for (int64_t a = 0; a < A; ++a) {
        arrived[a] = s->cur[a] == goal_b;
        for (int64_t i = sp[a] + 1; i < D; ++i) stack[a * D + i] = -1;
        for (int64_t i = 0; i <= sp[a]; ++i) {
          s->mark[stack[a * D + i]] = int32_t(a);
          if (arrived[a]) s->good[stack[a * D + i]] = 1;
        }
        for (int64_t i = 0; i < s->n_entered[a]; ++i) {
          const int32_t cell = s->entered[a * D + i];
          vis[cell] = true;
          if (!arrived[a] || s->mark[cell] != a) bad[cell] = true;
        }
      }
      for (int64_t i = 0; i < N; ++i) bad[i] = bad[i] && !s->good[i];
    };
  });
  return ffi::Error::Success();
}

// ---- pheromone deposits (jaco.engine.pheromone.deposit) ------------------------------------
// tau[targets[r, c]] += amounts[(r * C + c) % K] in row-major order, a target in [-M, 0) counting
// from the end and one outside [-M, M) dropped: jax's .at[].add(mode="drop"), XLA's scatter-add,
// which adds in the same order. The columns are walks: every column's targets in range come
// first, so a column is left once it has a target out of range (its later ones all are).
ffi::Error DepositImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::F32> tau, ffi::Buffer<ffi::S32> targets,
                       ffi::Buffer<ffi::F32> amounts, ffi::ResultBuffer<ffi::F32> out) {
  const auto td = tau.dimensions(), gd = targets.dimensions();
  const int64_t M = td[td.size() - 1], B = leading(td, 1);
  const int64_t R = gd[gd.size() - 2], C = gd[gd.size() - 1];
  const int64_t K = B ? int64_t(amounts.element_count()) / B : 0;
  const float* T0 = tau.typed_data();
  const int32_t* G0 = targets.typed_data();
  const float* A0 = amounts.typed_data();
  float* D0 = out->typed_data();
  for_each_colony(pool, B, [=]() {
    return [=, live = std::vector<int32_t>(C)](int64_t b) mutable {
      const float* src = T0 + b * M;
      float* dst = D0 + b * M;
      if (dst != src) std::memcpy(dst, src, M * sizeof(float));
      const int32_t* tg = G0 + b * R * C;
      const float* am = A0 + b * K;
      int64_t n_live = C;
      for (int64_t c = 0; c < C; ++c) live[c] = int32_t(c);
      for (int64_t r = 0; r < R && n_live; ++r) {
        int64_t kept = 0;
        for (int64_t i = 0; i < n_live; ++i) {
          const int64_t c = live[i], idx = r * C + c;
          const int64_t e = tg[idx] < 0 ? int64_t(tg[idx]) + M : int64_t(tg[idx]);
          if (e < 0 || e >= M) continue;  // the column's walk has ended
          dst[e] = dst[e] + am[K == 1 ? 0 : (K == C ? c : idx)];
          live[kept++] = int32_t(c);
        }
        n_live = kept;
      }
    };
  });
  return ffi::Error::Success();
}

// ---- the octile shortcut (jaco.engine.local_search.jax_shortcut) ------------------------------
// One pass along a path p_0 = start .. p_n: standing on p_i, the farthest p_j (2 <= j - i <= window)
// that a segment reaches through allowed moves and whose stretch p_i..p_j has other numbers of
// straight and diagonal steps than the segment (a segment is a shortest path in free space, so it
// is then shorter); form 0 (run 1 first) when free, else form 1; no such p_j: the step to p_{i+1}.
// Passes until one changes nothing, at most `passes`. Integers only.
struct Segment {
  int32_t k1, n1, k2, n2, straight, diag;
};

inline Segment segment(int32_t ra, int32_t ca, int32_t rb, int32_t cb, bool diagonal, const int32_t* move_of) {
  const int32_t dr = rb - ra, dc = cb - ca;
  const int32_t sr = (dr > 0) - (dr < 0), sc = (dc > 0) - (dc < 0);
  const int32_t adr = std::abs(dr), adc = std::abs(dc);
  const int32_t m = std::min(adr, adc), big = std::max(adr, adc);
  const int32_t along_rows = move_of[(sr + 1) * 3 + 1], along_cols = move_of[4 + sc];
  Segment s;
  if (diagonal) {  // octile: the diagonal run, the straight run along the longer axis
    s = Segment{move_of[(sr + 1) * 3 + (sc + 1)], m, adr > adc ? along_rows : along_cols, big - m, big - m, m};
  } else {  // no diagonal moves: the rows' run, the columns' run
    s = Segment{along_rows, adr, along_cols, adc, adr + adc, 0};
  }
  s.k1 = std::max(s.k1, 0);
  s.k2 = std::max(s.k2, 0);
  return s;
}

inline bool free_segment(int32_t cell, int32_t k1, int32_t n1, int32_t k2, int32_t n2, const uint8_t* bits,
                         const int32_t* off) {
  for (int32_t t = 0; t < n1; ++t, cell += off[k1])
    if (!((bits[cell] >> k1) & 1)) return false;
  for (int32_t t = 0; t < n2; ++t, cell += off[k2])
    if (!((bits[cell] >> k2) & 1)) return false;
  return true;
}

struct ShortcutScratch {
  std::vector<int32_t> path, full, rows, cols, n_straight, n_diag, out;
};

// One path (column `c` of the step-major (S, C) buffer `in`) into the same column of `result`.
void shortcut_path(const int32_t* in, int32_t* result, int64_t S, int64_t C, int64_t c, int32_t start,
                   const uint8_t* bits, const int32_t* off, bool diagonal, const int32_t* move_of, int64_t window,
                   int64_t passes, ShortcutScratch& s) {
  const int32_t width = -off[0];  // move 0 is (-1, 0)
  s.path.clear();
  for (int64_t t = 0; t < S; ++t)
    if (in[t * C + c] >= 0) s.path.push_back(in[t * C + c]);
  for (int64_t pass = 0; pass < passes; ++pass) {
    const int64_t n = int64_t(s.path.size());
    s.full.assign(1, start);
    s.full.insert(s.full.end(), s.path.begin(), s.path.end());
    s.rows.resize(n + 1);
    s.cols.resize(n + 1);
    s.n_straight.assign(n + 1, 0);
    s.n_diag.assign(n + 1, 0);
    for (int64_t i = 0; i <= n; ++i) {
      s.rows[i] = s.full[i] / width;
      s.cols[i] = s.full[i] % width;
      if (i > 0) {
        const bool diag = s.rows[i] != s.rows[i - 1] && s.cols[i] != s.cols[i - 1];
        s.n_straight[i] = s.n_straight[i - 1] + !diag;
        s.n_diag[i] = s.n_diag[i - 1] + diag;
      }
    }
    s.out.clear();
    bool changed = false;
    for (int64_t i = 0; i < n;) {
      int64_t found = 0;
      int form = 0;
      for (int64_t d = std::min<int64_t>(window, n - i); d >= 2; --d) {
        const int64_t j = i + d;
        const Segment g = segment(s.rows[i], s.cols[i], s.rows[j], s.cols[j], diagonal, move_of);
        if (g.straight == s.n_straight[j] - s.n_straight[i] && g.diag == s.n_diag[j] - s.n_diag[i]) continue;
        if (free_segment(s.full[i], g.k1, g.n1, g.k2, g.n2, bits, off)) {
          found = d;
          break;
        }
        if (free_segment(s.full[i], g.k2, g.n2, g.k1, g.n1, bits, off)) {
          found = d;
          form = 1;
          break;
        }
      }
      const int64_t d = found ? found : 1;
      const Segment g = segment(s.rows[i], s.cols[i], s.rows[i + d], s.cols[i + d], diagonal, move_of);
      const int32_t k1 = form ? g.k2 : g.k1, n1 = form ? g.n2 : g.n1, k2 = form ? g.k1 : g.k2, n2 = form ? g.n1 : g.n2;
      int32_t cell = s.full[i];
      for (int32_t t = 0; t < n1; ++t) s.out.push_back(cell += off[k1]);
      for (int32_t t = 0; t < n2; ++t) s.out.push_back(cell += off[k2]);
      changed = changed || found;
      i += d;
    }
    s.path.swap(s.out);
    if (!changed) break;
  }
  for (int64_t t = 0; t < S; ++t) result[t * C + c] = t < int64_t(s.path.size()) ? s.path[t] : -1;
}

ffi::Error ShortcutImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::S32> cells, ffi::Buffer<ffi::U8> bits,
                        ffi::Buffer<ffi::S32> start, ffi::Buffer<ffi::S32> offsets, ffi::Buffer<ffi::PRED> diagonal,
                        ffi::Buffer<ffi::S32> move_of, ffi::ResultBuffer<ffi::S32> out, int64_t window, int64_t passes) {
  const auto cd = cells.dimensions(), bd = bits.dimensions();
  const int64_t S = cd[cd.size() - 2], C = cd[cd.size() - 1], N = bd[bd.size() - 1];
  const int64_t B = leading(cd, 2);
  const int32_t* in0 = cells.typed_data();
  const uint8_t* bits0 = bits.typed_data();
  const int32_t *st = start.typed_data(), *off0 = offsets.typed_data(), *mv0 = move_of.typed_data();
  const bool* dg = diagonal.typed_data();
  int32_t* out0 = out->typed_data();
  for_each_colony(pool, B * C, [=]() {
    return [=, s = std::make_shared<ShortcutScratch>()](int64_t task) {
      const int64_t b = task / C, c = task % C;
      shortcut_path(in0 + b * S * C, out0 + b * S * C, S, C, c, st[b], bits0 + b * N, off0 + b * 8, dg[b],
                    mv0 + b * 9, window, passes, *s);
    };
  });
  return ffi::Error::Success();
}

// ---- the improved APF's next cell of every cell (jaco.potential.apf_next) -------------------------
// Dong & Zhao 2021, 3.1–3.2: from cell p, the target t starts at the goal; while the segment p→t
// has a last blocked cell o, eq. (4) picks the free cell beside o's obstacle (8-connected
// component) of least angular deviation from p→t outside the obstacle's angular span; then p
// moves to its allowed neighbour best aligned with t (eq. 5). Every comparison is on integers or
// on the same float32 values as the JAX version (exact integers, one division, additions).
struct ApfMap {
  int32_t w = 0, h = 0, n = 0;
  std::vector<uint8_t> free;
  std::vector<int32_t> lab;           // component (smallest flat index in it), -1 on free cells
  std::vector<int32_t> slot;          // component -> its row in the CSR lists below (by label)
  std::vector<int32_t> edge_at, edge;  // outline cells (blocked, a free or off-map 8-neighbour)
  std::vector<int32_t> beside_at, beside;  // free cells 8-adjacent to the component (repeats kept)
};

inline float dia(float x, float y) {  // jaco.apf._dia: a pseudo-angle in (-2, 2]
  const float f = y / (std::fabs(x) + std::fabs(y));
  return x >= 0.0f ? f : (y >= 0.0f ? 2.0f - f : -2.0f - f);
}

inline int32_t floor_div(int32_t a, int32_t b) {  // b > 0
  const int32_t q = a / b;
  return (a % b != 0 && a < 0) ? q - 1 : q;
}

void build_apf_map(ApfMap& m, const bool* free, int64_t n, int32_t w, const int32_t* moves) {
  m.n = int32_t(n);
  m.w = w;
  m.h = int32_t(n / w);
  m.free.assign(free, free + n);
  m.lab.assign(n, -1);
  std::vector<int32_t> queue;
  auto neighbour = [&](int32_t i, int k, int32_t& j) {
    const int32_t r = i / w + moves[2 * k], c = i % w + moves[2 * k + 1];
    if (r < 0 || r >= m.h || c < 0 || c >= w) return false;
    j = r * w + c;
    return true;
  };
  int32_t n_comp = 0;
  m.slot.assign(n, -1);
  for (int32_t s = 0; s < n; ++s) {  // in index order: a component's label is its smallest index
    if (m.free[s] || m.lab[s] >= 0) continue;
    m.slot[s] = n_comp++;
    m.lab[s] = s;
    queue.assign(1, s);
    for (size_t q = 0; q < queue.size(); ++q)
      for (int k = 0; k < 8; ++k) {
        int32_t j;
        if (neighbour(queue[q], k, j) && !m.free[j] && m.lab[j] < 0) {
          m.lab[j] = s;
          queue.push_back(j);
        }
      }
  }
  std::vector<int32_t> edge_count(n_comp + 1, 0), beside_count(n_comp + 1, 0);
  std::vector<uint8_t> outline(n, 0);
  for (int32_t i = 0; i < n; ++i)
    for (int k = 0; k < 8; ++k) {
      int32_t j;
      const bool in = neighbour(i, k, j);
      if (!m.free[i] && (!in || m.free[j])) outline[i] = 1;
      if (m.free[i] && in && !m.free[j]) beside_count[m.slot[m.lab[j]] + 1] += 1;
    }
  for (int32_t i = 0; i < n; ++i)
    if (outline[i]) edge_count[m.slot[m.lab[i]] + 1] += 1;
  for (int32_t c = 0; c < n_comp; ++c) {
    edge_count[c + 1] += edge_count[c];
    beside_count[c + 1] += beside_count[c];
  }
  m.edge_at = edge_count;
  m.beside_at = beside_count;
  m.edge.assign(edge_count[n_comp], 0);
  m.beside.assign(beside_count[n_comp], 0);
  for (int32_t i = 0; i < n; ++i) {
    if (outline[i]) m.edge[edge_count[m.slot[m.lab[i]]]++] = i;
    for (int k = 0; k < 8; ++k) {
      int32_t j;
      if (m.free[i] && neighbour(i, k, j) && !m.free[j]) m.beside[beside_count[m.slot[m.lab[j]]]++] = i;
    }
  }
}

// The last blocked cell of the closed supercover of segment a→b (jaco.potential._last_blocked_j).
int32_t last_blocked(const ApfMap& m, int32_t a0, int32_t a1, int32_t b0, int32_t b1) {
  const int32_t dr = b0 - a0, dc = b1 - a1;
  const int32_t sy = (dr > 0) - (dr < 0), sx = (dc > 0) - (dc < 0);
  const int32_t adr = std::abs(dr), adc = std::abs(dc);
  int32_t best_proj = -2147483647, best = -1;
  auto consider = [&](int32_t r, int32_t c) {
    const int32_t proj = (r - a0) * dr + (c - a1) * dc, idx = r * m.w + c;
    if (m.free[std::min(std::max(idx, 0), m.n - 1)]) return;
    if (proj > best_proj || (proj == best_proj && idx > best)) best_proj = proj, best = idx;
  };
  int32_t i = 0, j = 0, r = a0, c = a1;
  while (i < adc || j < adr) {
    const int32_t lhs = (2 * i + 1) * adr, rhs = (2 * j + 1) * adc;
    const bool vx = lhs <= rhs, vy = lhs >= rhs;
    if (vx && vy) {
      consider(r, c + sx);
      consider(r + sy, c);
    }
    if (vy) r += sy;
    if (vx) c += sx;
    consider(r, c);
    i += vx;
    j += vy;
  }
  return best;
}

// Eq. (4) (jaco.potential._pick_j): the new target beside component k, or false.
bool apf_pick(const ApfMap& m, int32_t pi, int32_t p0, int32_t p1, int32_t& t0, int32_t& t1, int32_t o) {
  const int32_t slot = m.slot[m.lab[o]], k = m.lab[o];
  const int32_t u0 = t0 - p0, u1 = t1 - p1;
  static const int32_t corners[4][2] = {{-1, -1}, {-1, 1}, {1, -1}, {1, 1}};
  float dx[4], dy[4];
  for (int q = 0; q < 4; ++q) {
    dx[q] = float(corners[q][0] * u0 + corners[q][1] * u1);
    dy[q] = float(u0 * corners[q][1] - u1 * corners[q][0]);
  }
  float lo = INFINITY, hi = -INFINITY;
  auto corners_of = [&](int32_t r, int32_t c) {
    const int32_t v0 = 2 * (r - p0), v1 = 2 * (c - p1);
    const float x = float(v0 * u0 + v1 * u1), y = float(u0 * v1 - u1 * v0);
    for (int q = 0; q < 4; ++q) {
      const float a = dia(x + dx[q], y + dy[q]);
      lo = std::min(lo, a);
      hi = std::max(hi, a);
    }
  };
  for (int32_t e = m.edge_at[slot]; e < m.edge_at[slot + 1]; ++e) corners_of(m.edge[e] / m.w, m.edge[e] % m.w);
  // The band along the ray behind p (jaco.potential._span).
  const int32_t d0 = -u0, d1 = -u1;
  const bool swap = std::abs(d0) > std::abs(d1);
  const int32_t pm = swap ? p0 : p1, pn = swap ? p1 : p0, dm = swap ? d0 : d1, dn = swap ? d1 : d0;
  const int32_t size = swap ? m.h : m.w, sm = dm < 0 ? -1 : 1, adm = std::max(std::abs(dm), 1);
  for (int32_t j = -2;; ++j) {
    const int32_t a = pm + sm * j;
    if (!(j < 0 || (a >= 0 && a < size))) break;
    const int32_t base = pn + floor_div(std::max(j, 0) * dn, adm);
    for (int32_t across = -3; across <= 3; ++across) {
      const int32_t b = base + across, r = swap ? a : b, c = swap ? b : a;
      if (r >= 0 && r < m.h && c >= 0 && c < m.w && m.lab[r * m.w + c] == k) corners_of(r, c);
    }
  }
  const int32_t ti = t0 * m.w + t1;
  float best_dev = INFINITY;
  int32_t best_near = INT32_MAX, best = INT32_MAX;
  for (int32_t e = m.beside_at[slot]; e < m.beside_at[slot + 1]; ++e) {
    const int32_t cell = m.beside[e];
    if (cell == pi || cell == ti) continue;
    const int32_t r = cell / m.w, c = cell % m.w, v0 = 2 * (r - p0), v1 = 2 * (c - p1);
    const float phi = dia(float(v0 * u0 + v1 * u1), float(u0 * v1 - u1 * v0));
    if (!(phi > hi || phi < lo)) continue;
    const float dev = std::fabs(phi);
    const int32_t near = (r - p0) * (r - p0) + (c - p1) * (c - p1);
    if (dev < best_dev || (dev == best_dev && (near < best_near || (near == best_near && cell < best))))
      best_dev = dev, best_near = near, best = cell;
  }
  if (best == INT32_MAX) return false;
  t0 = best / m.w;
  t1 = best % m.w;
  return true;
}

int32_t apf_next_cell(const ApfMap& m, int32_t i, int32_t goal, const int32_t* nbr, const int32_t* moves) {
  if (i == goal) return i;
  if (!m.free[i]) return -1;
  const int32_t p0 = i / m.w, p1 = i % m.w;
  int32_t t0 = goal / m.w, t1 = goal % m.w;
  int32_t o = last_blocked(m, p0, p1, t0, t1);
  int32_t s0 = t0, s1 = t1, power = 1, lam = 0;  // Brent's cycle detection (the chain depends on t alone)
  bool ok = true;
  for (int32_t level = 0; o >= 0 && ok && level < m.h + m.w; ++level) {
    const bool found = apf_pick(m, i, p0, p1, t0, t1, o);
    if (found) o = last_blocked(m, p0, p1, t0, t1);
    ok = found && !(t0 == s0 && t1 == s1);
    if (++lam == power) s0 = t0, s1 = t1, power *= 2, lam = 0;
  }
  if (!(ok && o < 0)) return -1;
  const int32_t d0 = t0 - p0, d1 = t1 - p1;
  const int32_t* row = nbr + int64_t(i) * 8;
  int best = -1;
  float best_score = -INFINITY;
  for (int k = 0; k < 8; ++k) {
    if (row[k] < 0) continue;
    const float len = (std::abs(moves[2 * k]) + std::abs(moves[2 * k + 1]) == 2) ? kSqrt2 : 1.0f;
    const float score = float(moves[2 * k] * d0 + moves[2 * k + 1] * d1) / len;
    if (best < 0 || score > best_score) best = k, best_score = score;
  }
  return best < 0 ? -1 : row[best];
}

ffi::Error ApfNextImpl(ffi::ThreadPool pool, ffi::Buffer<ffi::PRED> free, ffi::Buffer<ffi::S32> nbr,
                       ffi::Buffer<ffi::S32> goal, ffi::Buffer<ffi::S32> offsets, ffi::Buffer<ffi::S32> moves,
                       ffi::ResultBuffer<ffi::S32> next) {
  const auto fd = free.dimensions();
  const int64_t N = fd[fd.size() - 1], B = leading(fd, 1);
  constexpr int64_t kChunk = 256;  // walkers per task: tasks are taken in turn by the threads
  const int64_t per = (N + kChunk - 1) / kChunk;
  std::vector<ApfMap> maps(B);
  for (int64_t b = 0; b < B; ++b)
    build_apf_map(maps[b], free.typed_data() + b * N, N, -offsets.typed_data()[b * 8], moves.typed_data());
  const int32_t* nb0 = nbr.typed_data();
  const int32_t* gl = goal.typed_data();
  const int32_t* mv = moves.typed_data();
  int32_t* out = next->typed_data();
  const ApfMap* mp = maps.data();
  for_each_colony(pool, B * per, [=]() {
    return [=](int64_t task) {
      const int64_t b = task / per, lo = (task % per) * kChunk, hi = std::min(lo + kChunk, N);
      for (int64_t i = lo; i < hi; ++i)
        out[b * N + i] = apf_next_cell(mp[b], int32_t(i), gl[b], nb0 + b * N * 8, mv);
    };
  });
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

ffi::Error StoppedImpl(ffi::Buffer<ffi::S32> /*iteration: keeps the call inside the loop*/,
                       ffi::ResultBuffer<ffi::PRED> out) {
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
                                  .Ret<ffi::Buffer<ffi::S8>>()    // moves (..., S, A)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // cells (..., S, A)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // steps (..., A)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // diagonal steps (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // arrived (..., A)
                                  .Ret<ffi::Buffer<ffi::PRED>>()  // visited (..., N)
                                  .Attr<int64_t>("steplimit")
                                  .Attr<bool>("exploit"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoBacktrack, BacktrackImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // tau (..., N)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // detour rows (..., N, 8)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // weight factors (..., N, 8), with table
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
                                  .Attr<int64_t>("steplimit")
                                  .Attr<bool>("exploit")
                                  .Attr<bool>("table"));

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoDeposit, DepositImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // tau (..., M)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // targets (..., R, C)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // amounts (..., K): K = 1, C or R·C
                                  .Ret<ffi::Buffer<ffi::F32>>()); // tau (..., M), aliasing the input

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

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoApfNext, ApfNextImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::PRED>>()  // free (..., N)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // neighbours (..., N, 8), -1 where not allowed
                                  .Arg<ffi::Buffer<ffi::S32>>()   // goal (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move offsets (..., 8)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // moves (..., 8, 2) (row, col)
                                  .Ret<ffi::Buffer<ffi::S32>>()); // next (..., N)

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoShortcut, ShortcutImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::S32>>()   // paths (..., S, C), -1 padded
                                  .Arg<ffi::Buffer<ffi::U8>>()    // allowed moves, one bit each (..., N)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // start (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move offsets (..., 8)
                                  .Arg<ffi::Buffer<ffi::PRED>>()  // any diagonal move allowed (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move index of (dr, dc) (..., 9)
                                  .Ret<ffi::Buffer<ffi::S32>>()   // shortened paths (..., S, C)
                                  .Attr<int64_t>("window")
                                  .Attr<int64_t>("passes"));


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
// -1: the widest set this CPU runs; another set is taken only where it was built and the CPU runs it.
__attribute__((visibility("default"))) int jaco_isa_set(int i) {
  if (i == -1) i = widest_isa();
  if (!isa_runs(i)) return -1;
  current_isa.store(i);
  return 0;
}
}
