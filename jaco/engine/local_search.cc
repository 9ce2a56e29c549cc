// The octile shortcut as an XLA FFI kernel for the CPU (jaco.engine.native.shortcut): the same paths
// as jax_shortcut in local_search.py.
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

}  // namespace

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
