// IACA's backtracking walk as an XLA FFI kernel for the CPU (jaco.planners.iaca.native_backtrack_walk):
// the same moves, pheromone and stacks bit for bit as jax_backtrack_walk in iaca.py (thesis ch. 4).
// Float operations in the JAX walk's order, no fused multiply-add (-ffp-contract=off), powers by the
// integer tables of jaco/engine/bitexact.py; uniforms from walk_shared.h.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <memory>
#include <mutex>
#include <vector>

#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

namespace {

#include "kernel_threads.h"
#include "walk_shared.h"

// ---- IACA's backtracking walk (jaco.planners.iaca.jax_backtrack_walk) -------------------------------

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

}  // namespace

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
