// The dying-ant walk (jaco.engine.walk.jax_walk) with L ants of a colony in L SIMD lanes.
//
// setup.py compiles this file once per instruction set: JACO_ISA names the set (the function is
// walk_lanes_<JACO_ISA>), JACO_LANES its lane count, and the compiler flags let it use the set's
// vector registers (SSE2: 4 lanes, AVX2: 8, AVX-512: 16). The lanes are GCC/Clang vector types,
// with the set's own instructions where they pay (row transposes, permutes, masks; gathers for
// the uniforms; with AVX-512 a scatter for the edges); the arithmetic is the same source for every
// set, so every set takes the same moves.
//
// Every lane does its ant's float operations of the JAX walk in the same order (the running sums
// added left to right, one multiply for the target, no fused multiply-add: -ffp-contract=off), so
// the moves are the JAX walk's bit for bit. A lane whose ant stops (goal, dead end, step limit)
// takes the next ant at once, of its colony or of the group's next colony, so the lanes stay busy
// however long the walks are, and idle only when the group's last ants walk. A lane's cells are
// indices into the group's tables (colony j's cell i is j·N + i: its weights row, tabu word and
// visited flag), so a step reads every lane's row from one base whatever colony each lane walks.
//
// Tabu lists are bits, set once the ant has left the cell after it (the cell it just left is
// compared in a register). With tabu planes (small maps) each ant has its own bit, and one scan at
// the end gives the cells visited and clears them; else tabu[cell] has bit l for the ant of lane l,
// cleared along the ant's path when it stops, and every step stores the cells entered. Uniforms:
// each lane holds U = 2L uniforms of its ant, L Threefry blocks drawn together (one vector pass)
// when the ant starts and whenever it has used them all.
//
// Nothing here may be shared with the other objects (see walk_shared.h): everything has internal
// linkage but the one entry point.

#include <cstdint>
#include <cstring>
#include <math.h>

#include <utility>

#include "walk_lanes.h"

#if defined(__AVX2__) || defined(__AVX512F__)
#include <immintrin.h>
#endif

#ifndef JACO_ISA
#define JACO_ISA baseline
#endif
#ifndef JACO_LANES
#define JACO_LANES 4
#endif
#define JACO_CAT2(a, b) a##b
#define JACO_CAT(a, b) JACO_CAT2(a, b)

namespace {

#include "walk_shared.h"

constexpr int L = JACO_LANES;
constexpr int U = 2 * L;
// A call's last ants step alone in scalar code once no more than kAlone lanes walk and no ant is
// left to load (walk_alone): 2 of 16 lanes, 1 of 8 or 4 (measured on solves: docs/native.md).
constexpr int kAlone = L >= 16 ? 2 : 1;
static_assert(L <= 32, "the tabu bits of a cell are one uint32");

// L lanes as one vector (GCC/Clang vector extensions: element-wise arithmetic, comparisons that
// give -1 or 0 per lane); selects are bitwise, so a selected float keeps its bits.
typedef float vf __attribute__((vector_size(4 * L)));
typedef int32_t vi __attribute__((vector_size(4 * L)));
typedef uint32_t vu __attribute__((vector_size(4 * L)));

// Uniforms of steps 2·block0 .. 2·block0 + U − 1 of one ant (walk_shared.h).
inline void draw(uint32_t k0, uint32_t k1, uint32_t ant, uint32_t block0, float* out) {
  draw_blocks<vu, vf>(k0, k1, ant, block0, out);
}

inline vi bits_of(vf x) { return bits_as<vi>(x); }
inline vf float_of(vi x) { return bits_as<vf>(x); }
// base[index[l]] of every lane, the vector built in registers (element inserts): a vector
// written lane by lane in memory and read back whole stalls the CPU (store forwarding fails).
template <typename V, typename T, size_t... l>
inline V load_lanes(const T* base, vi index, std::index_sequence<l...>) {
  return V{base[index[l]]...};
}

// base[index] of every lane: one gather instruction where the set has one for L lanes.
inline vi gather(const int32_t* base, vi index) {
  vi out;
#if defined(__AVX512F__) && JACO_LANES == 16
  __m512i i, r;
  std::memcpy(&i, &index, sizeof i);
  r = _mm512_i32gather_epi32(i, base, 4);
  std::memcpy(&out, &r, sizeof out);
#elif defined(__AVX2__) && JACO_LANES == 8
  __m256i i, r;
  std::memcpy(&i, &index, sizeof i);
  r = _mm256_i32gather_epi32(base, i, 4);
  std::memcpy(&out, &r, sizeof out);
#else
  out = load_lanes<vi>(base, index, std::make_index_sequence<L>());
#endif
  return out;
}
inline vf gather(const float* base, vi index) {
  vf out;
#if defined(__AVX512F__) && JACO_LANES == 16
  __m512i i;
  __m512 r;
  std::memcpy(&i, &index, sizeof i);
  r = _mm512_i32gather_ps(i, base, 4);
  std::memcpy(&out, &r, sizeof out);
#elif defined(__AVX2__) && JACO_LANES == 8
  __m256i i;
  __m256 r;
  std::memcpy(&i, &index, sizeof i);
  r = _mm256_i32gather_ps(base, i, 4);
  std::memcpy(&out, &r, sizeof out);
#else
  out = load_lanes<vf>(base, index, std::make_index_sequence<L>());
#endif
  return out;
}

#if defined(__AVX2__)
// out[k] = (W[i0 + k], ..., W[i7 + k]): eight rows of 8 floats transposed.
inline void transpose8(const float* W, int32_t i0, int32_t i1, int32_t i2, int32_t i3, int32_t i4, int32_t i5,
                       int32_t i6, int32_t i7, __m256 out[8]) {
  const __m256 r0 = _mm256_loadu_ps(W + i0), r1 = _mm256_loadu_ps(W + i1), r2 = _mm256_loadu_ps(W + i2),
               r3 = _mm256_loadu_ps(W + i3), r4 = _mm256_loadu_ps(W + i4), r5 = _mm256_loadu_ps(W + i5),
               r6 = _mm256_loadu_ps(W + i6), r7 = _mm256_loadu_ps(W + i7);
  const __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1), t2 = _mm256_unpacklo_ps(r2, r3),
               t3 = _mm256_unpackhi_ps(r2, r3), t4 = _mm256_unpacklo_ps(r4, r5), t5 = _mm256_unpackhi_ps(r4, r5),
               t6 = _mm256_unpacklo_ps(r6, r7), t7 = _mm256_unpackhi_ps(r6, r7);
  const __m256 q0 = _mm256_shuffle_ps(t0, t2, 0x44), q1 = _mm256_shuffle_ps(t0, t2, 0xEE),
               q2 = _mm256_shuffle_ps(t1, t3, 0x44), q3 = _mm256_shuffle_ps(t1, t3, 0xEE),
               q4 = _mm256_shuffle_ps(t4, t6, 0x44), q5 = _mm256_shuffle_ps(t4, t6, 0xEE),
               q6 = _mm256_shuffle_ps(t5, t7, 0x44), q7 = _mm256_shuffle_ps(t5, t7, 0xEE);
  out[0] = _mm256_permute2f128_ps(q0, q4, 0x20);
  out[1] = _mm256_permute2f128_ps(q1, q5, 0x20);
  out[2] = _mm256_permute2f128_ps(q2, q6, 0x20);
  out[3] = _mm256_permute2f128_ps(q3, q7, 0x20);
  out[4] = _mm256_permute2f128_ps(q0, q4, 0x31);
  out[5] = _mm256_permute2f128_ps(q1, q5, 0x31);
  out[6] = _mm256_permute2f128_ps(q2, q6, 0x31);
  out[7] = _mm256_permute2f128_ps(q3, q7, 0x31);
}
#endif

// The 8 move weights of every lane's cell as 8 vectors (w[k][l] = W[row[l] + k]): each row is 8
// floats in a row, so where the set has them, L row loads and a transpose (no gathers).
inline void move_weights(const float* W, vi row, vf w[8]) {
#if defined(__AVX512F__) && JACO_LANES == 16
  // Rows l and l + 8 in the two halves of one register, so that the AVX2 transpose's steps take
  // both halves at once; its last step (the 128-bit blocks) as one two-register permute. The
  // result is built in registers: halves stored apart and read back whole stall the CPU.
  __m512 r[8], t[8], q[8];
  for (int i = 0; i < 8; ++i)
    r[i] = _mm512_insertf32x8(_mm512_castps256_ps512(_mm256_loadu_ps(W + row[i])), _mm256_loadu_ps(W + row[i + 8]), 1);
  for (int i = 0; i < 8; i += 2) {
    t[i] = _mm512_unpacklo_ps(r[i], r[i + 1]);
    t[i + 1] = _mm512_unpackhi_ps(r[i], r[i + 1]);
  }
  for (int i = 0; i < 8; i += 4) {
    q[i] = _mm512_shuffle_ps(t[i], t[i + 2], 0x44);
    q[i + 1] = _mm512_shuffle_ps(t[i], t[i + 2], 0xEE);
    q[i + 2] = _mm512_shuffle_ps(t[i + 1], t[i + 3], 0x44);
    q[i + 3] = _mm512_shuffle_ps(t[i + 1], t[i + 3], 0xEE);
  }
  const __m512i low = _mm512_setr_epi32(0, 1, 2, 3, 16, 17, 18, 19, 8, 9, 10, 11, 24, 25, 26, 27);
  const __m512i high = _mm512_setr_epi32(4, 5, 6, 7, 20, 21, 22, 23, 12, 13, 14, 15, 28, 29, 30, 31);
  for (int k = 0; k < 4; ++k) {
    const __m512 a = _mm512_permutex2var_ps(q[k], low, q[k + 4]), b = _mm512_permutex2var_ps(q[k], high, q[k + 4]);
    std::memcpy(&w[k], &a, sizeof a);
    std::memcpy(&w[k + 4], &b, sizeof b);
  }
#elif defined(__AVX2__) && JACO_LANES % 8 == 0
  union Halves {  // lanes 8h .. 8h + 7 in part[h]
    vf whole;
    __m256 part[L / 8];
  } moves[8];
  for (int h = 0; h < L / 8; ++h) {
    __m256 t[8];
    transpose8(W, row[8 * h], row[8 * h + 1], row[8 * h + 2], row[8 * h + 3], row[8 * h + 4], row[8 * h + 5],
               row[8 * h + 6], row[8 * h + 7], t);
    for (int k = 0; k < 8; ++k) moves[k].part[h] = t[k];
  }
  for (int k = 0; k < 8; ++k) w[k] = moves[k].whole;
#else
  for (int k = 0; k < 8; ++k) w[k] = gather(W + k, row);
#endif
}

#if defined(__AVX2__) && JACO_LANES % 8 == 0
#define JACO_ROWS 1
// The tabu words of every lane's 3x3 neighbourhood: marks[3 (r + 1) + c + 1][l] = tabu[cell[l] +
// r·width + c], as three loads of 4 words per lane (one a row) and a transpose, where the per-move
// look-up would take 8 gathers.
inline void neighbourhood(const uint32_t* tabu, vi cell, int32_t width, vi marks[9]) {
#if defined(__AVX512F__) && JACO_LANES == 16
  // The 128-bit blocks of x[i] hold lanes i, i + 4, i + 8 and i + 12; the unpacks then work on all
  // four blocks at once, and the result is built in registers (see move_weights).
  for (int r = 0; r < 3; ++r) {
    __m512i x[4];
    for (int i = 0; i < 4; ++i) {
      auto words = [&](int l) {
        return _mm_loadu_si128(reinterpret_cast<const __m128i*>(tabu + cell[l] + (r - 1) * width - 1));
      };
      x[i] = _mm512_inserti32x4(_mm512_inserti32x4(_mm512_inserti32x4(_mm512_castsi128_si512(words(i)), words(i + 4), 1),
                                                   words(i + 8), 2),
                                words(i + 12), 3);
    }
    const __m512i t0 = _mm512_unpacklo_epi32(x[0], x[1]), t1 = _mm512_unpackhi_epi32(x[0], x[1]);
    const __m512i t2 = _mm512_unpacklo_epi32(x[2], x[3]), t3 = _mm512_unpackhi_epi32(x[2], x[3]);
    const __m512i m0 = _mm512_unpacklo_epi64(t0, t2), m1 = _mm512_unpackhi_epi64(t0, t2), m2 = _mm512_unpacklo_epi64(t1, t3);
    std::memcpy(&marks[3 * r], &m0, sizeof m0);
    std::memcpy(&marks[3 * r + 1], &m1, sizeof m1);
    std::memcpy(&marks[3 * r + 2], &m2, sizeof m2);
  }
#else
  union Halves {
    vi whole;
    __m256i part[L / 8];
  } out[9];
  for (int h = 0; h < L / 8; ++h)
    for (int r = 0; r < 3; ++r) {
      __m256i x[4];
      for (int i = 0; i < 4; ++i) {  // lanes i and i + 4 of this half, 4 words from column -1 each
        const uint32_t* lo = tabu + cell[8 * h + i] + (r - 1) * width - 1;
        const uint32_t* hi = tabu + cell[8 * h + i + 4] + (r - 1) * width - 1;
        x[i] = _mm256_loadu2_m128i(reinterpret_cast<const __m128i*>(hi), reinterpret_cast<const __m128i*>(lo));
      }
      const __m256i t0 = _mm256_unpacklo_epi32(x[0], x[1]), t1 = _mm256_unpackhi_epi32(x[0], x[1]);
      const __m256i t2 = _mm256_unpacklo_epi32(x[2], x[3]), t3 = _mm256_unpackhi_epi32(x[2], x[3]);
      out[3 * r].part[h] = _mm256_unpacklo_epi64(t0, t2);
      out[3 * r + 1].part[h] = _mm256_unpackhi_epi64(t0, t2);
      out[3 * r + 2].part[h] = _mm256_unpacklo_epi64(t1, t3);
    }
  for (int i = 0; i < 9; ++i) marks[i] = out[i].whole;
#endif
}
#else
#define JACO_ROWS 0
#endif

// Where move k of jaco.moves.MOVES, (dr, dc), is in a 3x3 neighbourhood: 3 (dr + 1) + dc + 1 (a
// constant index: the 8 vectors stay in registers).
constexpr int kAround[8] = {1, 5, 7, 3, 2, 8, 6, 0};

inline vi pick(vi mask, vi a, vi b) { return (a & mask) | (b & ~mask); }
inline vf pick(vi mask, vf a, vf b) { return float_of(pick(mask, bits_of(a), bits_of(b))); }

// The lanes' state: lane l walks the ant whose step slots start at `ant[l]` (its colony's j·S·A
// plus its index), stands on `cur[l]`, came from `prev[l]` (-1 at the start) and has taken `t[l]`
// steps; `uniform[l][i]` is the uniform of its step drawn[l] + i. Its colony's goal, first edge
// (j·N·8) and q0 (with 1 − q0 as the wheel's scale) are per lane too; they are read, not carried.
struct Lanes {
  vi cur, prev, t, drawn, diagonal, ant, live;  // live: -1 while the lane walks an ant
  vi plane, bit;  // the ant's tabu plane (word offset) and bit, with tabu planes
  vi goal, first_edge;
  vf q0, q_scale;
  float uniform[L][U];
};

// Every lane's choice at once (an idle lane computes one too, unused): the roulette of
// jaco.engine.walk.choose over the weights of the moves into cells not tabu. A lane's tabu cells
// are the marked ones and its previous cell, which is marked only when the ant leaves the cell
// after it (so the gathers of a step never wait for the marks of the step before).
template <bool Exploit, bool Planes>
inline void choose_lanes(const Lanes& s, const LaneColony& c, int32_t n_cells, const vi offset[8], vi& chosen,
                         vi& ok) {
  const uint32_t* tabu = c.tabu;
  const vi zero = s.cur - s.cur, top_cell = zero + (n_cells - 1), row = s.cur * 8;
  vi bit, at;
  for (int l = 0; l < L; ++l) {
    bit[l] = int32_t(1u << l);
    at[l] = l * U;
  }
  if (Planes) bit = s.bit;
  const vi plane = Planes ? s.plane : zero;
  vf u = gather(&s.uniform[0][0], at + s.t - s.drawn);
  vf w[8];
  move_weights(c.weights, row, w);
  vi around[9];
#if JACO_ROWS
  const bool rows = c.width > 0;
  if (rows) neighbourhood(tabu, s.cur + plane, c.width, around);
#else
  const bool rows = false;
#endif
  for (int k = 0; k < 8; ++k) {  // a forbidden move has weight 0: any cell will do for its tabu look-up
    vi nb = s.cur + offset[k], marks;
    if (rows) {  // a cell off the map or in the next row: its weight is 0, its marks do not matter
      marks = around[kAround[k]];
    } else {
      const vi in = pick(nb < zero, zero, pick(nb > top_cell, top_cell, nb));
      marks = gather(reinterpret_cast<const int32_t*>(tabu), in + plane);
    }
    const vi free = ((marks & bit) == zero) & (nb != s.prev);
    w[k] = float_of(bits_of(w[k]) & free);  // 0.0f where tabu
  }
  vf sum[8];
  sum[0] = w[0];
  for (int k = 1; k < 8; ++k) sum[k] = sum[k - 1] + w[k];
  const vf total = sum[7];
  vi best = zero, greedy = zero;
  if (Exploit) {  // the argmax, ties to the lowest index, when u < q0
    vf top = w[0];
    for (int k = 1; k < 8; ++k) {
      const vi higher = w[k] > top;
      best = pick(higher, zero + k, best);
      top = pick(higher, w[k], top);
    }
    greedy = u < s.q0;
    u = (u - s.q0) / s.q_scale;
  }
  const vf target = u * total, below = float_of(bits_of(total) - 1);
  const vf x = pick(below < target, below, target);  // min_of(target, below)
  vi k = zero;
  for (int i = 0; i < 8; ++i) k -= sum[i] <= x;
  chosen = pick(greedy, best, k);
  ok = total > 0.0f;  // else a dead end: the ant dies
}

inline unsigned lanes_set(vi mask) {  // bit l: lane l's mask is set
#if defined(__AVX512F__) && JACO_LANES == 16
  __m512i m;
  std::memcpy(&m, &mask, sizeof m);
  return _mm512_movepi32_mask(m);
#elif defined(__AVX2__) && JACO_LANES == 8
  __m256 m;
  std::memcpy(&m, &mask, sizeof m);
  return unsigned(_mm256_movemask_ps(m));
#else
  unsigned m = 0;
  for (int l = 0; l < L; ++l) m |= unsigned(mask[l] != 0) << l;
  return m;
#endif
}

// offset[chosen[l]] of every lane: one permute where the set has one.
inline vi move_offset(const int32_t* offsets, vi chosen) {
#if defined(__AVX512F__) && JACO_LANES == 16
  __m512i c, r;
  std::memcpy(&c, &chosen, sizeof c);
  r = _mm512_permutexvar_epi32(c, _mm512_castsi256_si512(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(offsets))));
  vi out;
  std::memcpy(&out, &r, sizeof out);
  return out;
#elif defined(__AVX2__) && JACO_LANES == 8
  __m256i c, r;
  std::memcpy(&c, &chosen, sizeof c);
  r = _mm256_permutevar8x32_epi32(_mm256_loadu_si256(reinterpret_cast<const __m256i*>(offsets)), c);
  vi out;
  std::memcpy(&out, &r, sizeof out);
  return out;
#else
  return gather(offsets, chosen & 7);  // a dead end counts 8 (masked out later)
#endif
}

}  // namespace

namespace {
// No step yet in this call's columns of the step buffer, which hold the last walks' steps (each
// column its steps, then 8N: jaco.engine.walk.walk's `previous`): only the rows those walks used
// are cleared (found by bisection, as a row after an unused one is unused), and the rest are
// already 8N. Loops, not std::fill_n: walk_shared.h says why.
void clear_columns(const LaneColony& c) {
  const int64_t A = c.n_ants, S = c.steplimit, first = c.ant_begin, end = c.ant_end;
  const int32_t none = 8 * c.n_cells;
  auto used = [&](int64_t t) {
    bool any = false;
    for (int64_t a = first; a < end; ++a) any |= c.edges[t * A + a] != none;
    return any;
  };
  int64_t rows = 0, unused = S;  // rows [0, rows) used, [unused, S) not
  while (rows < unused) {
    const int64_t mid = (rows + unused) / 2;
    if (used(mid))
      rows = mid + 1;
    else
      unused = mid;
  }
  if (first == 0 && end == A) {
    for (int64_t i = 0; i < rows * A; ++i) c.edges[i] = none;
  } else {
    for (int64_t t = 0; t < rows; ++t)
      for (int64_t a = first; a < end; ++a) c.edges[t * A + a] = none;
  }
}

// Once a group's walks end: its colonies' cells visited from their tabu planes (the cells the ants
// left; finish stores the last two of each ant), and the planes zero again.
void clear_planes(const LaneColony& c, int64_t n_colonies) {
  const int64_t cells = n_colonies * c.n_cells;
  // The group's colonies' flags, one after another, as bytes: GCC does not vectorise a store of
  // `bool` from a comparison (this loop, scalar, was about 4 % of a solve's walk).
  uint8_t* __restrict visited = reinterpret_cast<uint8_t*>(c.visited);
  for (int64_t p = 0; p < c.tabu_planes; ++p) {
    const uint32_t* __restrict plane = c.tabu + p * cells;
    for (int64_t i = 0; i < cells; ++i) visited[i] |= uint8_t(plane[i] != 0);
  }
  std::memset(c.tabu, 0, size_t(c.tabu_planes * cells) * sizeof *c.tabu);  // the planes lie one after another
}

// One function for the lanes' loop and its two per-lane steps (load, finish): longer than the
// rest of jaco's functions, but the lane state stays in registers and the loop reads as one.
// Planes: each ant its own tabu bit (LaneColony::tabu_planes), else each lane.
template <bool Planes>
void walk_group(const LaneColony* colonies, int64_t n_colonies) {
  const LaneColony& c = colonies[0];  // the group's tables start at colony 0's (walk_lanes.h)
  const int64_t A = c.n_ants, S = c.steplimit;
  const int32_t N = c.n_cells;
  uint32_t* tabu = c.tabu;
  // A colony's step slots are cleared when its first ant starts, so that they are still in the
  // cache when its ants write them (all of a group's at once: 8 colonies' slots, 384 KB on the
  // benchmark, went out of the cache before the walks reached them; not cleared at all, the walk
  // alone ran 1.15x as long: its scattered stores then miss the cache).
  auto open = [&](int64_t j) {
    clear_columns(colonies[j]);
    std::memset(colonies[j].visited, 0, colonies[j].n_cells);
    colonies[j].visited[colonies[j].start] = true;
  };
  open(0);
  vi offset[8];
  for (int k = 0; k < 8; ++k)
    for (int l = 0; l < L; ++l) offset[k][l] = c.offsets[k];

  Lanes s;
  const vi zero = offset[0] - offset[0];
  s.cur = zero + c.start;  // an idle lane marks its cell visited at every step (a bit a lane): colony 0's start is
  s.goal = s.first_edge = zero;
  s.prev = zero - 1;
  s.t = s.drawn = s.diagonal = s.ant = s.live = s.plane = s.bit = zero;
  s.q0 = s.q_scale = float_of(zero);
  int64_t colony = 0, next = c.ant_begin;
  int32_t ant_of[L], colony_of[L];  // the lane's ant and colony, for its results
  int n_live = 0;
  // Lane l takes the next ant that has a step to take (an ant on the goal, or with no step
  // allowed by the limit, is finished at once), or idles.
  auto load = [&](int l) {
    while (colony < n_colonies) {
      const LaneColony& k = colonies[colony];
      for (; next < k.ant_end; ++next) {
        if (k.start == k.goal || S == 0) {
          k.n_steps[next] = 0;
          k.n_diagonal[next] = 0;
          k.arrived[next] = k.start == k.goal;
          continue;
        }
        const int32_t cells = int32_t(colony) * N;
        ant_of[l] = int32_t(next);
        colony_of[l] = int32_t(colony);
        s.ant[l] = int32_t(colony * S * A + next++);
        s.cur[l] = cells + k.start;
        s.goal[l] = cells + k.goal;
        s.first_edge[l] = 8 * cells;
        s.q0[l] = k.q0;
        s.q_scale[l] = max_of(1.0f - k.q0, 1e-12f);
        s.prev[l] = -1;
        s.t[l] = s.diagonal[l] = s.drawn[l] = 0;
        s.live[l] = -1;
        if (Planes) {  // ant r of the call's part: bit r % 32 of plane r / 32
          const int64_t r = ant_of[l] - k.ant_begin;
          s.plane[l] = int32_t(r >> 5) * int32_t(n_colonies) * N;
          s.bit[l] = int32_t(1u << (r & 31));
        }
        draw(k.k0, k.k1, uint32_t(ant_of[l]), 0, s.uniform[l]);
        ++n_live;
        return;
      }
      if (++colony < n_colonies) {  // the group's next colony, opened just before its first ant
        next = colonies[colony].ant_begin;
        open(colony);
      }
    }
    s.live[l] = 0;
    s.t[l] = s.drawn[l] = 0;
  };
  // The ant of lane l stops: its results, and its marks cleared. Only cells it left are marked,
  // and those are the cells its steps came from (from·8 + move in its edges).
  auto finish = [&](int l) {
    const LaneColony& k = colonies[colony_of[l]];
    const int32_t a = ant_of[l], n = s.t[l], cells = colony_of[l] * N;
    const uint32_t clear = ~(1u << l);
    k.n_steps[a] = n;
    k.n_diagonal[a] = s.diagonal[l];
    k.arrived[a] = s.cur[l] == s.goal[l];
    if (Planes) {  // the cells it left are in its plane, but for the last (and the one it stands on)
      c.visited[s.cur[l]] = true;
      if (s.prev[l] >= 0) c.visited[s.prev[l]] = true;
    } else {
      for (int32_t i = 0; i < n; ++i) tabu[cells + (k.edges[int64_t(i) * A + a] >> 3)] &= clear;
    }
    --n_live;
  };
  for (int l = 0; l < L; ++l) load(l);

  const int32_t group_cells = int32_t(n_colonies) * N;
  // Lane l's ant has used its uniforms: the next U, from its step t on.
  auto draw_from = [&](int l, int32_t t) {
    const LaneColony& k = colonies[colony_of[l]];
    draw(k.k0, k.k1, uint32_t(ant_of[l]), uint32_t(t) >> 1, s.uniform[l]);
  };
  // The last ants of a call (no ant left to load, at most kAlone lanes live) take their steps in
  // scalar code, in turn (one step of each, so that their chains overlap): there a vector step
  // costs as much for them as for L. Each step does its lane's float operations (the roulette of
  // walk_shared.h is choose_lanes' for one lane).
  auto walk_alone = [&]() {
    int32_t cur[L], prev[L], t[L], drawn[L], diagonal[L];
    std::memcpy(cur, &s.cur, sizeof cur);
    std::memcpy(prev, &s.prev, sizeof prev);
    std::memcpy(t, &s.t, sizeof t);
    std::memcpy(drawn, &s.drawn, sizeof drawn);
    std::memcpy(diagonal, &s.diagonal, sizeof diagonal);
    for (unsigned live = lanes_set(s.live); live;) {
      for (unsigned m = live; m; m &= m - 1) {
        const int l = __builtin_ctz(m);
        const int32_t plane = Planes ? s.plane[l] : 0;  // the lane's tabu words and bit
        const uint32_t bit = Planes ? uint32_t(s.bit[l]) : 1u << l;
        float w[8];
        const float* row = c.weights + int64_t(cur[l]) * 8;
        for (int k = 0; k < 8; ++k) {  // a forbidden move has weight 0: any cell will do for its tabu look-up
          const int32_t nb = cur[l] + c.offsets[k], in = nb < 0 ? 0 : (nb > group_cells - 1 ? group_cells - 1 : nb);
          w[k] = (tabu[in + plane] & bit) == 0 && nb != prev[l] ? row[k] : 0.0f;
        }
        float total = w[0];
        for (int k = 1; k < 8; ++k) total = total + w[k];
        bool ended = !(total > 0.0f);  // a dead end: the ant dies
        if (!ended) {
          const int chosen = choose(w, s.uniform[l][t[l] - drawn[l]], s.q0[l], c.exploit);
          const int32_t cell = cur[l] + c.offsets[chosen];
          c.edges[int64_t(t[l]) * A + s.ant[l]] = cur[l] * 8 - s.first_edge[l] + chosen;
          if (!Planes) c.visited[cell] = true;
          if (prev[l] >= 0) tabu[prev[l] + plane] |= bit;
          prev[l] = cur[l];
          cur[l] = cell;
          diagonal[l] += chosen >= 4;
          ++t[l];
          ended = cell == s.goal[l] || t[l] == int32_t(S);
          if (!ended && t[l] - drawn[l] == U) draw_from(l, drawn[l] = t[l]);
        }
        if (ended) {
          s.cur[l] = cur[l];
          s.prev[l] = prev[l];
          s.t[l] = t[l];
          s.diagonal[l] = diagonal[l];
          finish(l);
          live &= ~(1u << l);
        }
      }
    }
  };
  while (n_live > 0) {
    if (n_live <= kAlone && colony >= n_colonies) {  // no ant left to load: the last ones alone
      walk_alone();
      break;
    }
    vi chosen, ok;
    if (c.exploit)
      choose_lanes<true, Planes>(s, c, group_cells, offset, chosen, ok);
    else
      choose_lanes<false, Planes>(s, c, group_cells, offset, chosen, ok);
    // The step of every walking lane with a move (the others keep their cell).
    const vi step = s.live & ok;
    const vi cell = pick(step, s.cur + move_offset(c.offsets, chosen), s.cur);
    const vi slot = s.t * int32_t(A) + s.ant;
    int32_t marked[L], entered[L], marking[L], bits[L];
    const vi from_move = s.cur * 8 - s.first_edge + chosen, marks = step & (s.prev >= zero);
    const vi marked_at = Planes ? s.prev + s.plane : s.prev;
    std::memcpy(marked, &marked_at, sizeof marked);
    std::memcpy(bits, &s.bit, sizeof bits);
    std::memcpy(entered, &cell, sizeof entered);
    std::memcpy(marking, &marks, sizeof marking);
    // Every lane's stores, with no branch on how many lanes stepped (a loop over the stepping
    // lanes mispredicted its exit at most steps): a lane that did not step stores into a sink,
    // and marks its own cell visited again (it is: the cell it stands on). With AVX-512 the edges
    // are one masked scatter of the lanes that stepped.
    uint32_t mark_sink;
#if defined(__AVX512F__) && JACO_LANES == 16
    {
      __m512i to, value;
      std::memcpy(&to, &slot, sizeof to);
      std::memcpy(&value, &from_move, sizeof value);
      _mm512_mask_i32scatter_epi32(c.edges, __mmask16(lanes_set(step)), to, value, 4);
    }
    for (int l = 0; l < L; ++l) {
      if (!Planes) c.visited[entered[l]] = true;
      *(marking[l] ? tabu + marked[l] : &mark_sink) |= Planes ? uint32_t(bits[l]) : 1u << l;
    }
#else
    int32_t at[L], edge[L], stepped[L], edge_sink;
    std::memcpy(at, &slot, sizeof at);
    std::memcpy(edge, &from_move, sizeof edge);
    std::memcpy(stepped, &step, sizeof stepped);
    for (int l = 0; l < L; ++l) {
      *(stepped[l] ? c.edges + at[l] : &edge_sink) = edge[l];
      if (!Planes) c.visited[entered[l]] = true;
      *(marking[l] ? tabu + marked[l] : &mark_sink) |= Planes ? uint32_t(bits[l]) : 1u << l;
    }
#endif
    s.prev = pick(step, s.cur, s.prev);
    s.cur = cell;
    s.t -= step;
    s.diagonal -= step & (chosen >= 4);
    const vi ended = s.live & (~ok | (cell == s.goal) | (s.t == int32_t(S)));
    for (unsigned m = lanes_set(ended); m; m &= m - 1) {
      const int l = __builtin_ctz(m);
      finish(l);
      load(l);
    }
    const vi refill = s.live & ~ended & ((s.t - s.drawn) == U);
    for (unsigned m = lanes_set(refill); m; m &= m - 1) {
      const int l = __builtin_ctz(m);
      draw_from(l, s.drawn[l] = s.t[l]);
    }
  }
  if (Planes) clear_planes(c, n_colonies);
}
}  // namespace

void JACO_CAT(walk_lanes_, JACO_ISA)(const LaneColony* colonies, int64_t n_colonies) {
  if (colonies[0].tabu_planes > 0)
    walk_group<true>(colonies, n_colonies);
  else
    walk_group<false>(colonies, n_colonies);
}
