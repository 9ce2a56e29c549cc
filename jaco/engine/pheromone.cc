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
#include <type_traits>
#include <vector>

#include "pheromone_lanes.h"
#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

extern "C" int jaco_isa_get();  // walk.cc: the instruction set in use, an index of JACO_ISA_LIST

namespace {

#include "kernel_threads.h"

// ---- pheromone deposits (jaco.engine.pheromone.deposit) ------------------------------------
// tau[targets[r, c]] += amounts[(r * C + c) % K] in row-major order, a target in [-M, 0) counting
// from the end and one outside [-M, M) dropped: jax's .at[].add(mode="drop"), XLA's scatter-add,
// which adds in the same order. The columns are walks: every column's targets in range come
// first, then only targets out of range, so a column is left at its first target out of range.
// Adding +0.0 leaves every float as it is but -0.0 (it becomes +0.0) and a signalling NaN (it
// is quieted): where the pheromone holds neither, the adds of a zero amount (a failed ant's, in
// most rules about half the steps) are skipped, the same result with less work. The check is made
// in the copy of the pheromone into the result, one pass (pheromone_lanes.cc: vectorised with the
// instruction set the walk uses).
bool copy_and_check_zero_adds(const float* src, float* dst, int64_t M) {
  using CopyCheck = bool (*)(const float*, float*, int64_t);
#ifdef JACO_HAVE_AVX2
  constexpr CopyCheck kAvx2 = copy_and_check_zero_adds_avx2;
#else
  constexpr CopyCheck kAvx2 = nullptr;
#endif
#ifdef JACO_HAVE_AVX512
  constexpr CopyCheck kAvx512 = copy_and_check_zero_adds_avx512;
#else
  constexpr CopyCheck kAvx512 = nullptr;
#endif
  constexpr CopyCheck kSets[] = {copy_and_check_zero_adds_baseline, kAvx2, kAvx512};  // JACO_ISA_LIST's order
  const int i = jaco_isa_get();  // only a set that was built and that this CPU runs
  return (i > 0 && i < 3 && kSets[i] ? kSets[i] : kSets[0])(src, dst, M);
}

bool is_plus_zero(float x) {
  uint32_t bits;
  std::memcpy(&bits, &x, 4);
  return bits == 0;
}

enum class Amounts { kOne, kPerColumn, kPerTarget };

// f(form) with the form of K amounts for C columns as a constant (one per column where K == C).
template <typename F>
auto with_form(int64_t K, int64_t C, F f) {
  if (K == C) return f(std::integral_constant<Amounts, Amounts::kPerColumn>());
  if (K == 1) return f(std::integral_constant<Amounts, Amounts::kOne>());
  return f(std::integral_constant<Amounts, Amounts::kPerTarget>());
}

// How many rows each column of live[0, n) walked, into rows: a column's targets in range come first,
// then only targets out of range (every walk records its steps so), so the first one out of range
// is found by bisection; all columns' bisections advance together, so their loads (each on its own
// cache line, the targets not yet in the cache) wait at the same time, not one after another.
void rows_walked(const int32_t* tg, int64_t M, int64_t R, int64_t C, const int32_t* live, int64_t n, int32_t* rows) {
  auto walks = [=](int64_t r, int64_t c) { return tg[r * C + c] >= -M && tg[r * C + c] < M; };
  std::fill(rows, rows + n, 0);
  if (R == 0) return;
  for (int64_t len = R; len > 1;) {  // rows[i] + len bounds the answer; len shrinks the same for all
    const int64_t half = len / 2;
    for (int64_t i = 0; i < n; ++i) rows[i] += int32_t(walks(rows[i] + half - 1, live[i]) * half);
    len -= half;
  }
  for (int64_t i = 0; i < n; ++i) rows[i] += walks(rows[i], live[i]);
}

// Calls add(element, index of the amount) for the adds of the columns live[0, n_live), row by row
// (XLA's order), each column until its walk ends. Between two ends of walks the columns are the
// same, so the loop over them tests nothing. rows is scratch, one per column.
template <Amounts form, typename AddOne>
void for_each_add(const int32_t* tg, int64_t M, int64_t R, int64_t C, int32_t* live, int64_t n_live, int32_t* rows,
                  AddOne add) {
  rows_walked(tg, M, R, C, live, n_live, rows);
  for (int64_t r = 0; n_live;) {
    int64_t end = R;
    for (int64_t i = 0; i < n_live; ++i) end = std::min<int64_t>(end, rows[i]);
    for (; r < end; ++r) {
      const int32_t* row = tg + r * C;
      for (int64_t i = 0; i < n_live; ++i) {
        const int64_t c = live[i], t = row[c];
        add(t < 0 ? t + M : t, form == Amounts::kPerTarget ? r * C + c : form == Amounts::kOne ? 0 : c);
      }
    }
    int64_t kept = 0;  // the columns whose walks go on
    for (int64_t i = 0; i < n_live; ++i)
      if (rows[i] > end) live[kept] = live[i], rows[kept++] = rows[i];
    n_live = kept;
  }
}

// The adds made at once, in XLA's order. Each form of the amounts has its own loop, with no test
// of the form per add; with skip_zero, a column whose one amount is +0.0 was never in live.
template <Amounts form>
void add_rows(float* dst, int64_t M, const int32_t* tg, int64_t R, int64_t C, const float* am, int32_t* live,
              int64_t n_live, int32_t* rows, bool skip_zero) {
  for_each_add<form>(tg, M, R, C, live, n_live, rows, [=](int64_t e, int64_t j) {
    if (!(form == Amounts::kPerTarget && skip_zero && is_plus_zero(am[j]))) dst[e] = dst[e] + am[j];
  });
}

// One add of a colony's list: the element and the amount, in the order they are added.
struct Add {
  int32_t e;
  float v;
};

// The adds of add_rows in order, written to `out` instead of made; returns how many.
template <Amounts form>
int64_t list_rows(Add* out, int64_t M, const int32_t* tg, int64_t R, int64_t C, const float* am, int32_t* live,
                  int64_t n_live, int32_t* rows, bool skip_zero) {
  int64_t n = 0;
  for_each_add<form>(tg, M, R, C, live, n_live, rows, [&](int64_t e, int64_t j) {
    out[n] = Add{int32_t(e), am[j]};
    n += !(form == Amounts::kPerTarget && skip_zero && is_plus_zero(am[j]));
  });
  return n;
}

// The adds of G colonies' lists, the i-th add of each colony in turn for i in [from, to): each
// colony's adds stay in their order, and the G chains of adds (a row of ants on one path adds to
// one element after another, each add waiting for the last) overlap instead of following one another.
struct Colony {
  float* dst;
  const Add* adds;
  int64_t n;
};

template <int G>
void add_interleaved(const Colony* col, int64_t from, int64_t to) {
  float* d[G];
  const Add* a[G];
  for (int k = 0; k < G; ++k) d[k] = col[k].dst, a[k] = col[k].adds;
  for (int64_t i = from; i < to; ++i)
    for (int k = 0; k < G; ++k) d[k][a[k][i].e] = d[k][a[k][i].e] + a[k][i].v;
}

// At most 8 colonies a group (8 chains overlap enough), and lists of at most 2^19 adds a thread (4 MiB).
constexpr int64_t kMaxGroup = 8, kMaxListed = int64_t(1) << 19;

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
  // Colonies are taken in groups, as large as leaves every thread a group, within the bounds above.
  const int64_t n_threads = std::max<int64_t>(pool.num_threads(), 1);
  const int64_t group = std::clamp<int64_t>(std::min(B / n_threads, kMaxListed / std::max<int64_t>(R * C, 1)), 1,
                                            kMaxGroup);
  const int64_t n_groups = B ? (B + group - 1) / group : 0;
  for_each_colony(pool, n_groups, [=]() {
    // The lists of a group, kept by the thread from call to call (uninitialised: written before read).
    thread_local std::unique_ptr<Add[]> lists;
    thread_local int64_t capacity = 0;
    if (group > 1 && capacity < group * R * C) lists.reset(new Add[size_t(capacity = group * R * C)]);
    return [=, live = std::vector<int32_t>(C), rows = std::vector<int32_t>(C), lists = lists.get()](int64_t g) mutable {
      const int64_t b0 = g * group, n_col = std::min(group, B - b0);
      Colony col[kMaxGroup];
      int64_t used = 0;
      for (int64_t k = 0; k < n_col; ++k) {
        const int64_t b = b0 + k;
        float* dst = D0 + b * M;
        const bool skip_zero = copy_and_check_zero_adds(T0 + b * M, dst, M);
        const int32_t* tg = G0 + b * R * C;
        const float* am = A0 + b * K;
        int64_t n_live = 0;
        for (int64_t c = 0; c < C; ++c)  // a column whose one amount is +0.0 adds nothing
          if (!(skip_zero && (K == C || K == 1) && is_plus_zero(am[K == 1 ? 0 : c]))) live[n_live++] = int32_t(c);
        if (n_col == 1)  // a colony alone adds at once
          return with_form(K, C, [&](auto form) {
            add_rows<decltype(form)::value>(dst, M, tg, R, C, am, live.data(), n_live, rows.data(), skip_zero);
          });
        const int64_t n = with_form(K, C, [&](auto form) {
          return list_rows<decltype(form)::value>(lists + used, M, tg, R, C, am, live.data(), n_live, rows.data(),
                                                  skip_zero);
        });
        col[k] = Colony{dst, nullptr, n};
        used += n;
      }
      for (int64_t k = 0, at = 0; k < n_col; at += col[k].n, ++k) col[k].adds = lists + at;
      // Longest list first: the colonies still adding are always the first `left`.
      std::sort(col, col + n_col, [](const Colony& x, const Colony& y) { return x.n > y.n; });
      int64_t from = 0;
      for (int64_t left = n_col; left > 0; --left) {
        const int64_t to = col[left - 1].n;
        switch (left) {
          case 8: add_interleaved<8>(col, from, to); break;
          case 7: add_interleaved<7>(col, from, to); break;
          case 6: add_interleaved<6>(col, from, to); break;
          case 5: add_interleaved<5>(col, from, to); break;
          case 4: add_interleaved<4>(col, from, to); break;
          case 3: add_interleaved<3>(col, from, to); break;
          case 2: add_interleaved<2>(col, from, to); break;
          default: add_interleaved<1>(col, from, to); break;
        }
        from = to;
      }
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
