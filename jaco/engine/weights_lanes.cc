// The roulette weights of a colony's moves, jaco.engine.weights.scaled_weights, bit for bit as
// XLA:CPU computes them:
//   w = where(valid, clip(exp(lw - top), 1e-30, 1), 0),
//   lw = where(valid, nan_to_num(α·log(max(τ, tiny)) + f, nan=-inf), -inf),  top = max of the cell's lw.
//
// XLA does not call a math library for float32 log and exp: it emits its own polynomials (those
// of Cephes, as Eigen has them), and LLVM fuses each multiply that feeds an add into one fused
// multiply-add where the CPU has FMA. The functions below are those polynomials, operation for
// operation, with the fused multiply-adds where XLA's code has them (`fused`) or a rounded
// multiply and add where it has none, under XLA's floating-point mode (denormals flushed to zero).
// experiments/check_xla_math.py compares them with XLA's on every float32 input, and
// jaco.engine.weights compares the kernel's weights with XLA's once per process before it uses it.
//
// setup.py compiles this file once per instruction set (JACO_ISA): AVX2 and AVX-512 take one
// cell's 8 moves in one 8-lane vector; the baseline computes the same operations one move at a time.
// Nothing here may be shared with the other objects (see walk_shared.h).

#include <cmath>
#include <cstdint>
#include <cstring>

#include "weights_lanes.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <xmmintrin.h>
#endif

#ifndef JACO_ISA
#define JACO_ISA baseline
#endif
#define JACO_CAT2(a, b) a##b
#define JACO_CAT(a, b) JACO_CAT2(a, b)

namespace {

inline float from_bits(uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}
inline uint32_t to_bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

// The constants of XLA's polynomials (xla/codegen/math: log_f32, exp_f32), as bit patterns.
constexpr uint32_t kTiny = 0x00800000u;            // the smallest normal float
constexpr uint32_t kSqrtHalf = 0x3F3504F3u;
constexpr uint32_t kLogP[9] = {0x3D9021BBu, 0xBDEBD1B8u, 0x3DEF251Au, 0xBDFE5D4Fu, 0x3E11E9BFu,
                               0xBE2AAE50u, 0x3E4CCEACu, 0xBE7FFFFCu, 0x3EAAAAAAu};
constexpr uint32_t kLn2Lo = 0xB95E8083u, kLn2Hi = 0x3F318000u, kLog2e = 0x3FB8AA3Bu;
constexpr uint32_t kExpP[5] = {0x39506967u, 0x3AB743CEu, 0x3C088908u, 0x3D2AA9C1u, 0x3E2AAAAAu};
constexpr float kFloatMax = 3.40282347e+38f;

// XLA's floating-point mode while it computes: denormal results flushed to zero, denormal inputs
// read as zero. Set for the kernel's work and put back after.
struct FlushDenormals {
#if defined(__x86_64__) || defined(__i386__)
  unsigned saved = _mm_getcsr();
  FlushDenormals() { _mm_setcsr(saved | 0x8040u); }
  ~FlushDenormals() { _mm_setcsr(saved); }
#endif
};

// ---- one move at a time ---------------------------------------------------------------------
template <bool kFused>
inline float mul_add(float a, float b, float c) {
  if (kFused) return std::fma(a, b, c);
  return a * b + c;  // two roundings (built with -ffp-contract=off)
}

// log(x) of x = max(τ, tiny): XLA's log_f32.
template <bool kFused>
float log_of(float x) {
  const uint32_t nan_mask = !(x > 0.0f) ? 0xFFFFFFFFu : 0u;  // x <= 0 or NaN: NaN
  const bool zero = x == 0.0f, inf = x == INFINITY;
  const float xc = (from_bits(kTiny) >= x || x != x) ? from_bits(kTiny) : x;
  const uint32_t b = to_bits(xc);
  float e = 1.0f + float(int32_t(b >> 23) - 127);
  const float m = from_bits((b & 0x807FFFFFu) | 0x3F000000u);
  const bool below = m < from_bits(kSqrtHalf);
  const float x1 = m - 1.0f;
  e = e - (below ? 1.0f : 0.0f);
  const float z = x1 + (below ? m : 0.0f);
  const float z2 = z * z, z3 = z2 * z;
  float y0 = mul_add<kFused>(z, from_bits(kLogP[0]), from_bits(kLogP[1]));
  float y1 = mul_add<kFused>(z, from_bits(kLogP[3]), from_bits(kLogP[4]));
  float y2 = mul_add<kFused>(z, from_bits(kLogP[6]), from_bits(kLogP[7]));
  y0 = mul_add<kFused>(y0, z, from_bits(kLogP[2]));
  y1 = mul_add<kFused>(y1, z, from_bits(kLogP[5]));
  y2 = mul_add<kFused>(y2, z, from_bits(kLogP[8]));
  float y = mul_add<kFused>(y0, z3, y1);
  y = mul_add<kFused>(y, z3, y2);
  const float s = mul_add<kFused>(y, z3, from_bits(kLn2Lo) * e);
  const float t = mul_add<kFused>(-0.5f, z2, z);
  const float r = mul_add<kFused>(from_bits(kLn2Hi), e, t + s);
  if (zero) return -INFINITY;
  if (inf) return INFINITY;
  return from_bits(to_bits(r) | nan_mask);
}

// exp(x): XLA's exp_f32.
template <bool kFused>
float exp_of(float x) {
  x = (x >= -87.8f || x != x) ? x : -87.8f;
  x = (x <= 88.8f || x != x) ? x : 88.8f;
  float n = std::floor(mul_add<kFused>(x, from_bits(kLog2e), 0.5f));
  n = (n >= -127.0f || n != n) ? n : -127.0f;
  n = (n <= 127.0f || n != n) ? n : 127.0f;
  float r = mul_add<kFused>(-from_bits(kLn2Hi), n, x);
  r = mul_add<kFused>(-from_bits(kLn2Lo), n, r);
  float p = mul_add<kFused>(r, from_bits(kExpP[0]), from_bits(kExpP[1]));
  for (int k = 2; k < 5; ++k) p = mul_add<kFused>(p, r, from_bits(kExpP[k]));
  p = mul_add<kFused>(p, r, 0.5f);
  const float y = 1.0f + mul_add<kFused>(p, r * r, r);
  return y * from_bits(uint32_t(int32_t(n) + 127) << 23);
}

// nan_to_num(nan=-inf) of α·log τ + f: NaN -> -inf -> -max, ±inf -> ±max.
inline float finite_or_max(float lw) {
  lw = lw != lw ? -INFINITY : lw;
  lw = lw == INFINITY ? kFloatMax : lw;
  return lw == -INFINITY ? -kFloatMax : lw;
}

inline float max_tiny(float t) { return t != t ? t : (t > from_bits(kTiny) ? t : from_bits(kTiny)); }

template <bool kFused>
void weights_scalar(const WeightsColony& c) {
  for (int64_t i = 0; c.cells && i < c.n_cells; ++i) c.log_tau[i] = log_of<kFused>(max_tiny(c.tau[i]));
  for (int64_t i = 0; i < c.n_cells; ++i) {
    float lw[8];
    float top = -INFINITY;
    for (int k = 0; k < 8; ++k) {
      const int32_t to = c.nbr[i * 8 + k];
      const float log_tau = c.cells ? c.log_tau[to >= 0 ? to : 0] : log_of<kFused>(max_tiny(c.tau[i * 8 + k]));
      lw[k] = to >= 0 ? finite_or_max(mul_add<kFused>(c.alpha, log_tau, c.factor[i * 8 + k])) : -INFINITY;
      top = lw[k] > top ? lw[k] : top;
    }
    top = std::isinf(top) ? 0.0f : top;
    for (int k = 0; k < 8; ++k) {
      float w = exp_of<kFused>(lw[k] - top);
      w = w < 1e-30f ? 1e-30f : (w > 1.0f ? 1.0f : w);
      c.out[i * 8 + k] = c.nbr[i * 8 + k] >= 0 ? w : 0.0f;
    }
  }
}

#if defined(__AVX2__)
// ---- one cell's 8 moves in 8 lanes (AVX2, FMA), two cells' in 16 (AVX-512) --------------------
// The functions below are written once for both widths, on the overloads that follow: each lane
// does the same IEEE operations at either width, so both give the same bits.
using V8 = __m256;
using M8 = __m256;  // a mask: all bits set where true
template <typename V>
V splat(uint32_t bits);
template <typename V>
V splat(float x);
template <>
inline V8 splat<V8>(uint32_t bits) { return _mm256_castsi256_ps(_mm256_set1_epi32(int32_t(bits))); }
template <>
inline V8 splat<V8>(float x) { return _mm256_set1_ps(x); }
inline V8 add(V8 a, V8 b) { return _mm256_add_ps(a, b); }
inline V8 sub(V8 a, V8 b) { return _mm256_sub_ps(a, b); }
inline V8 mul(V8 a, V8 b) { return _mm256_mul_ps(a, b); }
inline V8 vmax(V8 a, V8 b) { return _mm256_max_ps(a, b); }  // b where either is NaN
inline V8 vmin(V8 a, V8 b) { return _mm256_min_ps(a, b); }
inline V8 vand(V8 a, V8 b) { return _mm256_and_ps(a, b); }
inline V8 vor(V8 a, V8 b) { return _mm256_or_ps(a, b); }
inline V8 floor_of(V8 x) { return _mm256_floor_ps(x); }
inline V8 fmadd(V8 a, V8 b, V8 c) { return _mm256_fmadd_ps(a, b, c); }
inline V8 fnmadd(V8 a, V8 b, V8 c) { return _mm256_fnmadd_ps(a, b, c); }
inline M8 less(V8 a, V8 b) { return _mm256_cmp_ps(a, b, _CMP_LT_OQ); }
inline M8 not_equal(V8 a, V8 b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_OQ); }  // false where either is NaN
inline M8 unordered(V8 x) { return _mm256_cmp_ps(x, x, _CMP_UNORD_Q); }
inline V8 select(M8 mask, V8 yes, V8 no) { return _mm256_blendv_ps(no, yes, mask); }
inline V8 keep(M8 mask, V8 x) { return _mm256_and_ps(mask, x); }  // 0 where not mask
inline V8 all_bits(M8 mask, V8 x) { return _mm256_or_ps(mask, x); }  // every bit set where mask
inline V8 exponent(V8 x) {  // float(biased exponent − 127)
  return _mm256_cvtepi32_ps(_mm256_sub_epi32(_mm256_srli_epi32(_mm256_castps_si256(x), 23), _mm256_set1_epi32(127)));
}
inline V8 pow2(V8 n) {  // 2^n of a whole n in [-127, 127]
  return _mm256_castsi256_ps(_mm256_slli_epi32(_mm256_add_epi32(_mm256_cvttps_epi32(n), _mm256_set1_epi32(127)), 23));
}
// A cell's largest move (no NaN left, so any order: the same value) in all 8 lanes of the cell.
inline V8 cell_max(V8 x) {
  x = _mm256_max_ps(x, _mm256_permute2f128_ps(x, x, 1));
  x = _mm256_max_ps(x, _mm256_shuffle_ps(x, x, _MM_SHUFFLE(1, 0, 3, 2)));
  return _mm256_max_ps(x, _mm256_shuffle_ps(x, x, _MM_SHUFFLE(2, 3, 0, 1)));
}
constexpr int cells_in(V8) { return 1; }
// The rows of an (N, 8) table of cell[0 .. cells_in − 1], and the rows written back.
inline void load_rows(const float* table, const int64_t* cell, V8& out) { out = _mm256_loadu_ps(table + cell[0] * 8); }
inline void store_rows(float* table, const int64_t* cell, V8 x) { _mm256_storeu_ps(table + cell[0] * 8, x); }
// Whether each move is allowed (nbr >= 0) and the pheromone the weight takes: the cell's per move,
// or that of the cell entered (log τ of it, from c.log_tau).
inline void load_moves(const WeightsColony& c, const int64_t* cell, M8& valid, V8& tau) {
  const __m256i to = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c.nbr + cell[0] * 8));
  valid = _mm256_castsi256_ps(_mm256_cmpgt_epi32(to, _mm256_set1_epi32(-1)));
  if (c.cells)
    tau = _mm256_i32gather_ps(c.log_tau, _mm256_max_epi32(to, _mm256_setzero_si256()), 4);
  else
    load_rows(c.tau, cell, tau);
}

#if defined(__AVX512F__)
using V16 = __m512;
using M16 = __mmask16;
template <>
inline V16 splat<V16>(uint32_t bits) { return _mm512_castsi512_ps(_mm512_set1_epi32(int32_t(bits))); }
template <>
inline V16 splat<V16>(float x) { return _mm512_set1_ps(x); }
inline V16 add(V16 a, V16 b) { return _mm512_add_ps(a, b); }
inline V16 sub(V16 a, V16 b) { return _mm512_sub_ps(a, b); }
inline V16 mul(V16 a, V16 b) { return _mm512_mul_ps(a, b); }
inline V16 vmax(V16 a, V16 b) { return _mm512_max_ps(a, b); }
inline V16 vmin(V16 a, V16 b) { return _mm512_min_ps(a, b); }
inline V16 vand(V16 a, V16 b) { return _mm512_and_ps(a, b); }
inline V16 vor(V16 a, V16 b) { return _mm512_or_ps(a, b); }
inline V16 floor_of(V16 x) { return _mm512_roundscale_ps(x, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC); }
inline V16 fmadd(V16 a, V16 b, V16 c) { return _mm512_fmadd_ps(a, b, c); }
inline V16 fnmadd(V16 a, V16 b, V16 c) { return _mm512_fnmadd_ps(a, b, c); }
inline M16 less(V16 a, V16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_LT_OQ); }
inline M16 not_equal(V16 a, V16 b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_OQ); }
inline M16 unordered(V16 x) { return _mm512_cmp_ps_mask(x, x, _CMP_UNORD_Q); }
inline V16 select(M16 mask, V16 yes, V16 no) { return _mm512_mask_blend_ps(mask, no, yes); }
inline V16 keep(M16 mask, V16 x) { return _mm512_maskz_mov_ps(mask, x); }
inline V16 all_bits(M16 mask, V16 x) { return _mm512_mask_mov_ps(x, mask, splat<V16>(0xFFFFFFFFu)); }
inline V16 exponent(V16 x) {
  return _mm512_cvtepi32_ps(_mm512_sub_epi32(_mm512_srli_epi32(_mm512_castps_si512(x), 23), _mm512_set1_epi32(127)));
}
inline V16 pow2(V16 n) {
  return _mm512_castsi512_ps(_mm512_slli_epi32(_mm512_add_epi32(_mm512_cvttps_epi32(n), _mm512_set1_epi32(127)), 23));
}
inline V16 cell_max(V16 x) {  // each half as V8's cell_max: the same pairs in the same order
  x = _mm512_max_ps(x, _mm512_shuffle_f32x4(x, x, _MM_SHUFFLE(2, 3, 0, 1)));
  x = _mm512_max_ps(x, _mm512_shuffle_ps(x, x, _MM_SHUFFLE(1, 0, 3, 2)));
  return _mm512_max_ps(x, _mm512_shuffle_ps(x, x, _MM_SHUFFLE(2, 3, 0, 1)));
}
constexpr int cells_in(V16) { return 2; }
inline void load_rows(const float* table, const int64_t* cell, V16& out) {
  out = _mm512_insertf32x8(_mm512_castps256_ps512(_mm256_loadu_ps(table + cell[0] * 8)), _mm256_loadu_ps(table + cell[1] * 8), 1);
}
inline void store_rows(float* table, const int64_t* cell, V16 x) {
  _mm256_storeu_ps(table + cell[0] * 8, _mm512_castps512_ps256(x));
  _mm256_storeu_ps(table + cell[1] * 8, _mm512_extractf32x8_ps(x, 1));
}
inline void load_moves(const WeightsColony& c, const int64_t* cell, M16& valid, V16& tau) {
  const __m512i to = _mm512_inserti32x8(
      _mm512_castsi256_si512(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(c.nbr + cell[0] * 8))),
      _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c.nbr + cell[1] * 8)), 1);
  valid = _mm512_cmpgt_epi32_mask(to, _mm512_set1_epi32(-1));
  if (c.cells)
    tau = _mm512_i32gather_ps(_mm512_max_epi32(to, _mm512_setzero_si512()), c.log_tau, 4);
  else
    load_rows(c.tau, cell, tau);
}
using Wide = V16;  // the width weights_lanes takes
#else
using Wide = V8;
#endif

template <bool kFused, typename V>
inline V mul_add(V a, V b, V c) {
  if (kFused) return fmadd(a, b, c);
  return add(mul(a, b), c);
}
template <bool kFused, typename V>
inline V neg_mul_add(V a, V b, V c) {  // c - a·b
  if (kFused) return fnmadd(a, b, c);
  return sub(c, mul(a, b));
}

// Each function takes K vectors at once, stage by stage: one cell's weights are a chain of some
// 70 dependent operations, and K independent chains keep the vector units busy.
#define EACH for (int k = 0; k < K; ++k)

// log(x) of x = max(τ, tiny) >= tiny (or NaN): XLA's log_f32, whose cases for x <= tiny and x = 0
// are left out (they cannot occur) and the others (NaN: NaN, +inf: +inf) kept.
template <bool kFused, int K, typename V>
inline void log_of(V (&x)[K]) {
  const V one = splat<V>(1.0f);
  V e[K], z[K], z2[K], z3[K], y0[K], y1[K], y2[K];
  decltype(less(one, one)) special[K];
  EACH special[k] = not_equal(x[k], splat<V>(INFINITY));  // false for NaN and +inf
  EACH e[k] = add(one, exponent(x[k]));
  EACH z[k] = vor(vand(x[k], splat<V>(0x807FFFFFu)), splat<V>(0x3F000000u));  // the mantissa m in [0.5, 1)
  EACH {
    const auto below = less(z[k], splat<V>(kSqrtHalf));
    e[k] = sub(e[k], keep(below, one));
    z[k] = add(sub(z[k], one), keep(below, z[k]));
  }
  EACH z2[k] = mul(z[k], z[k]);
  EACH z3[k] = mul(z2[k], z[k]);
  EACH y0[k] = mul_add<kFused>(z[k], splat<V>(kLogP[0]), splat<V>(kLogP[1]));
  EACH y1[k] = mul_add<kFused>(z[k], splat<V>(kLogP[3]), splat<V>(kLogP[4]));
  EACH y2[k] = mul_add<kFused>(z[k], splat<V>(kLogP[6]), splat<V>(kLogP[7]));
  EACH y0[k] = mul_add<kFused>(y0[k], z[k], splat<V>(kLogP[2]));
  EACH y1[k] = mul_add<kFused>(y1[k], z[k], splat<V>(kLogP[5]));
  EACH y2[k] = mul_add<kFused>(y2[k], z[k], splat<V>(kLogP[8]));
  EACH y0[k] = mul_add<kFused>(y0[k], z3[k], y1[k]);
  EACH y0[k] = mul_add<kFused>(y0[k], z3[k], y2[k]);
  EACH y0[k] = mul_add<kFused>(y0[k], z3[k], mul(splat<V>(kLn2Lo), e[k]));
  EACH y1[k] = neg_mul_add<kFused>(splat<V>(0.5f), z2[k], z[k]);
  EACH y0[k] = mul_add<kFused>(splat<V>(kLn2Hi), e[k], add(y1[k], y0[k]));
  // NaN: all bits set (XLA's NaN); +inf: +inf
  EACH x[k] = select(special[k], y0[k], all_bits(unordered(x[k]), vand(x[k], splat<V>(0x7F800000u))));
}

// exp(x) of x = lw - top in [-inf, 0]: XLA's exp_f32, whose clamps that cannot bind there (x <= 88.8,
// and the exponent n in [-127, 127]) are left out.
template <bool kFused, int K, typename V>
inline void exp_of(V (&x)[K]) {
  V n[K], r[K], p[K];
  EACH x[k] = vmax(x[k], splat<V>(-87.8f));  // x is never NaN here
  EACH n[k] = floor_of(mul_add<kFused>(x[k], splat<V>(kLog2e), splat<V>(0.5f)));
  EACH r[k] = neg_mul_add<kFused>(splat<V>(kLn2Hi), n[k], x[k]);
  EACH r[k] = neg_mul_add<kFused>(splat<V>(kLn2Lo), n[k], r[k]);
  EACH p[k] = mul_add<kFused>(r[k], splat<V>(kExpP[0]), splat<V>(kExpP[1]));
  for (int j = 2; j < 5; ++j) EACH p[k] = mul_add<kFused>(p[k], r[k], splat<V>(kExpP[j]));
  EACH p[k] = mul_add<kFused>(p[k], r[k], splat<V>(0.5f));
  EACH p[k] = add(splat<V>(1.0f), mul_add<kFused>(p[k], mul(r[k], r[k]), r[k]));
  EACH x[k] = mul(p[k], pow2(n[k]));
}

template <typename V>
inline V max_tiny(V t) { return vmax(splat<V>(kTiny), t); }  // maxps: a NaN τ (second) stays NaN

// The cells cell[0 .. K·cells_in(V) − 1], cells_in(V) to a vector.
template <bool kFused, int K, typename V>
inline void weights_of_cells(const WeightsColony& c, const int64_t* cell) {
  constexpr int C = cells_in(V());
  const V minus_inf = splat<V>(-INFINITY), max = splat<V>(kFloatMax), min = splat<V>(-kFloatMax);
  V lw[K];
  decltype(less(max, max)) valid[K];
  EACH {
    load_moves(c, cell + C * k, valid[k], lw[k]);
    if (!c.cells) lw[k] = max_tiny(lw[k]);
  }
  if (!c.cells) log_of<kFused, K>(lw);
  EACH {
    V factor;
    load_rows(c.factor, cell + C * k, factor);
    lw[k] = mul_add<kFused>(splat<V>(c.alpha), lw[k], factor);
  }
  // nan_to_num(nan=-inf): NaN and -inf -> -max, +inf -> max (maxps gives its second operand for a
  // NaN); then -inf where the move is forbidden
  EACH lw[k] = select(valid[k], vmin(vmax(lw[k], min), max), minus_inf);
  EACH {
    V top = cell_max(lw[k]);
    top = keep(not_equal(top, minus_inf), top);  // no move allowed: 0
    lw[k] = sub(lw[k], top);
  }
  exp_of<kFused, K>(lw);
  EACH store_rows(c.out, cell + C * k, keep(valid[k], vmin(vmax(lw[k], splat<V>(1e-30f)), splat<V>(1.0f))));
}

template <bool kFused>
void weights_lanes(const WeightsColony& c) {
  constexpr int K = 8, C = cells_in(Wide());
  int64_t i = 0;
  for (; c.cells && i + 8 <= c.n_cells; i += 8) {
    V8 x[1] = {max_tiny(_mm256_loadu_ps(c.tau + i))};
    log_of<kFused, 1>(x);
    _mm256_storeu_ps(c.log_tau + i, x[0]);
  }
  for (; c.cells && i < c.n_cells; ++i) c.log_tau[i] = log_of<kFused>(max_tiny(c.tau[i]));
  // A cell with no allowed move (an obstacle: a quarter of a typical map) has weights 0 and is
  // never entered; the others are taken K·C at a time.
  int64_t cell[K * C];
  int n = 0;
  for (i = 0; i < c.n_cells; ++i) {
    const __m256i to = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(c.nbr + i * 8));
    if (_mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(to, _mm256_set1_epi32(-1)))) == 0) {
      _mm256_storeu_ps(c.out + i * 8, _mm256_setzero_ps());
      continue;
    }
    cell[n++] = i;
    if (n == K * C) {
      weights_of_cells<kFused, K, Wide>(c, cell);
      n = 0;
    }
  }
  if (n) {  // the last cells K·C at a time too, the last one repeated (its row written again, the same bits)
    for (int k = n; k < K * C; ++k) cell[k] = cell[n - 1];
    weights_of_cells<kFused, K, Wide>(c, cell);
  }
}
#undef EACH
#endif

template <bool kFused>
void log_exp(const float* x, int64_t n, float* log_out, float* exp_out) {
#if defined(__AVX2__)
  constexpr int64_t W = 8 * cells_in(Wide());  // the lanes weights_lanes takes, so that the tests check them
  const int64_t index[2] = {0, 1};  // a vector of W floats as the rows of cells 0 (and 1)
  for (int64_t i = 0; i < n; i += W) {  // the last vector padded, so that every x takes the vector code
    const size_t m = sizeof(float) * size_t(n - i < W ? n - i : W);
    float in[W] = {}, lg[W], ex[W];
    std::memcpy(in, x + i, m);
    Wide a[1], b[1];
    load_rows(in, index, b[0]);
    a[0] = max_tiny(b[0]);
    log_of<kFused, 1>(a);
    exp_of<kFused, 1>(b);
    store_rows(lg, index, a[0]);
    store_rows(ex, index, b[0]);
    std::memcpy(log_out + i, lg, m);
    std::memcpy(exp_out + i, ex, m);
  }
#else
  for (int64_t i = 0; i < n; ++i) {
    log_out[i] = log_of<kFused>(max_tiny(x[i]));
    exp_out[i] = exp_of<kFused>(x[i]);
  }
#endif
}

}  // namespace

void JACO_CAT(log_exp_, JACO_ISA)(const float* x, int64_t n, bool fused, float* log_out, float* exp_out) {
  FlushDenormals mode;
  if (fused)
    log_exp<true>(x, n, log_out, exp_out);
  else
    log_exp<false>(x, n, log_out, exp_out);
}

void JACO_CAT(move_weights_, JACO_ISA)(const WeightsColony& c) {
  FlushDenormals mode;
#if defined(__AVX2__)
  if (c.fused)
    weights_lanes<true>(c);
  else
    weights_lanes<false>(c);
#else
  if (c.fused)
    weights_scalar<true>(c);
  else
    weights_scalar<false>(c);
#endif
}
