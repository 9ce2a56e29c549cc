// The improved APF's next cell of every cell as an XLA FFI kernel for the CPU (jaco.potential.native_apf_next):
// the same table as jaco.potential.apf_next.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <math.h>
#include <memory>
#include <mutex>
#include <vector>

#include "xla/ffi/api/ffi.h"

namespace ffi = xla::ffi;

namespace {

#include "kernel_threads.h"
#include "walk_shared.h"  // kSqrt2

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

}  // namespace

XLA_FFI_DEFINE_HANDLER_SYMBOL(JacoApfNext, ApfNextImpl,
                              ffi::Ffi::Bind()
                                  .Ctx<ffi::ThreadPool>()
                                  .Arg<ffi::Buffer<ffi::PRED>>()  // free (..., N)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // neighbours (..., N, 8), -1 where not allowed
                                  .Arg<ffi::Buffer<ffi::S32>>()   // goal (...)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // move offsets (..., 8)
                                  .Arg<ffi::Buffer<ffi::S32>>()   // moves (..., 8, 2) (row, col)
                                  .Ret<ffi::Buffer<ffi::S32>>()); // next (..., N)
