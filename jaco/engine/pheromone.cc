// The pheromone deposit as an XLA FFI kernel for the CPU (jaco.engine.native.deposit): the scatter-add
// of jaco.engine.pheromone.deposit, adding in XLA's order, over the steps the ants walked.
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

// ---- pheromone deposits (jaco.engine.pheromone.deposit) ------------------------------------
// tau[targets[r, c]] += amounts[(r * C + c) % K] in row-major order, a target in [-M, 0) counting
// from the end and one outside [-M, M) dropped: jax's .at[].add(mode="drop"), XLA's scatter-add,
// which adds in the same order. The columns are walks: every column's targets in range come
// first, so a column is left once it has a target out of range (its later ones all are).
// Adding +0.0 leaves every float as it is but -0.0 (it becomes +0.0) and a signalling NaN (it
// is quieted): where the pheromone holds neither, the adds of a zero amount (a failed ant's, in
// most rules about half the steps) are skipped, the same result with less work. The check is made
// in the copy of the pheromone into the result, one pass (branch-free, so that it is vectorised).
bool copy_and_check_zero_adds(const float* src, float* dst, int64_t M) {
  uint32_t odd = 0;
  for (int64_t i = 0; i < M; ++i) {
    uint32_t bits;
    std::memcpy(&bits, src + i, 4);
    odd |= uint32_t(bits == 0x80000000u) | uint32_t((bits & 0x7fffffffu) > 0x7f800000u);
    dst[i] = src[i];
  }
  return odd == 0;
}

bool is_plus_zero(float x) {
  uint32_t bits;
  std::memcpy(&bits, &x, 4);
  return bits == 0;
}

enum class Amounts { kOne, kPerColumn, kPerTarget };

// The adds, row by row (XLA's order), of the columns in live[0, n_live); a column is left once it
// has a target out of range (its later ones all are). Each form of the amounts has its own loop,
// with no test of the form per add; with skip_zero, a column whose one amount is +0.0 was never
// in live.
template <Amounts form>
void add_rows(float* dst, int64_t M, const int32_t* tg, int64_t R, int64_t C, const float* am, int32_t* live,
              int64_t n_live, bool skip_zero) {
  for (int64_t r = 0; r < R && n_live; ++r) {
    int64_t kept = 0;
    for (int64_t i = 0; i < n_live; ++i) {
      const int64_t c = live[i], idx = r * C + c;
      const int64_t e = tg[idx] < 0 ? int64_t(tg[idx]) + M : int64_t(tg[idx]);
      if (e < 0 || e >= M) continue;  // the column's walk has ended
      live[kept++] = int32_t(c);
      if (form == Amounts::kPerTarget) {
        if (!(skip_zero && is_plus_zero(am[idx]))) dst[e] = dst[e] + am[idx];
      } else {
        dst[e] = dst[e] + am[form == Amounts::kOne ? 0 : c];
      }
    }
    n_live = kept;
  }
}

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
      float* dst = D0 + b * M;
      const bool skip_zero = copy_and_check_zero_adds(T0 + b * M, dst, M);
      const int32_t* tg = G0 + b * R * C;
      const float* am = A0 + b * K;
      int64_t n_live = 0;
      for (int64_t c = 0; c < C; ++c)  // a column whose one amount is +0.0 adds nothing
        if (!(skip_zero && (K == C || K == 1) && is_plus_zero(am[K == 1 ? 0 : c]))) live[n_live++] = int32_t(c);
      if (K == C)
        add_rows<Amounts::kPerColumn>(dst, M, tg, R, C, am, live.data(), n_live, false);
      else if (K == 1)
        add_rows<Amounts::kOne>(dst, M, tg, R, C, am, live.data(), n_live, false);
      else
        add_rows<Amounts::kPerTarget>(dst, M, tg, R, C, am, live.data(), n_live, skip_zero);
    };
  });
  return ffi::Error::Success();
}

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoDeposit, DepositImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::F32>>()   // tau (..., M)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // targets (..., R, C)
                                  .Arg<ffi::Buffer<ffi::F32>>()   // amounts (..., K): K = 1, C or R·C
                                  .Ret<ffi::Buffer<ffi::F32>>()); // tau (..., M), a new buffer (aliased, XLA copied it back into its loop)
