// IACA's backtracking walk of one colony, step by step (iaca_lanes.h): the same moves, pheromone
// and stacks bit for bit as jax_backtrack_walk in iaca.py (thesis ch. 4). Float operations in
// the JAX walk's order, no fused multiply-add (-ffp-contract=off), powers by the integer tables of
// jaco/engine/bitexact.py; uniforms and the roulette from walk_shared.h.
//
// An ant's 8 moves are computed together in 8 vector lanes: the two table powers of each move
// (eq. 4-1 with eq. 4-5), each lane doing exactly the operations of bitexact.power. τ^α depends
// on the cell alone, so it is kept per cell and recomputed where the local update changed τ
// (the same lanes, the same bits); η^β depends on the ant's tabu list, so each step. setup.py
// compiles this file once per instruction set, as walk_lanes.cc (JACO_ISA names the set); with
// AVX2 the table look-ups are gathers and the floor one instruction.
//
// Nothing here may be shared with the other objects (see walk_shared.h): everything has internal
// linkage but the one table of entry points.

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <math.h>
#include <vector>

#include "iaca_lanes.h"

#if defined(__AVX2__)
#include <immintrin.h>
#endif

#ifndef JACO_ISA
#define JACO_ISA baseline
#endif
#define JACO_CAT2(a, b) a##b
#define JACO_CAT(a, b) JACO_CAT2(a, b)

// 8 lanes are two vectors of SSE2: GCC warns that such a value would be passed differently with
// AVX; nothing here is called from another object.
#pragma GCC diagnostic ignored "-Wpsabi"

namespace {

#include "walk_shared.h"

// ---- the 8 moves of an ant in 8 lanes (GCC/Clang vector types; selects are bitwise) ----------
typedef float f8 __attribute__((vector_size(32)));
typedef int32_t i8 __attribute__((vector_size(32)));
typedef uint32_t u8 __attribute__((vector_size(32)));

inline f8 as_f8(i8 x) { return bits_as<f8>(x); }
inline i8 as_i8(f8 x) { return bits_as<i8>(x); }
inline f8 select(i8 mask, f8 a, f8 b) { return as_f8((mask & as_i8(a)) | (~mask & as_i8(b))); }
inline f8 splat(float x) { return f8{x, x, x, x, x, x, x, x}; }

template <typename T>
inline i8 gather(const T* table, i8 index) {
  i8 out;
#if defined(__AVX2__)
  __m256i i, r;
  std::memcpy(&i, &index, sizeof i);
  r = _mm256_i32gather_epi32(reinterpret_cast<const int*>(table), i, 4);
  std::memcpy(&out, &r, sizeof out);
#else
  for (int k = 0; k < 8; ++k) std::memcpy(&out[k], table + index[k], 4);
#endif
  return out;
}

// table[index] and table[index + 1] of each lane. With AVX2 the two are one 8-byte element, and
// two gathers of 4 such pairs load fewer elements than two gathers of 8.
inline void gather_pair(const int32_t* table, i8 index, i8& lo, i8& hi) {
#if defined(__AVX2__)
  __m256i i;
  std::memcpy(&i, &index, sizeof i);
  const long long* pairs = reinterpret_cast<const long long*>(table);
  const __m256 a = _mm256_castsi256_ps(_mm256_i32gather_epi64(pairs, _mm256_castsi256_si128(i), 4));
  const __m256 b = _mm256_castsi256_ps(_mm256_i32gather_epi64(pairs, _mm256_extracti128_si256(i, 1), 4));
  // a: lanes 0..3 as (lo, hi) pairs, b: lanes 4..7. Shuffled: lo0 lo1 lo4 lo5 | lo2 lo3 lo6 lo7.
  const __m256d l = _mm256_castps_pd(_mm256_shuffle_ps(a, b, 0x88)), h = _mm256_castps_pd(_mm256_shuffle_ps(a, b, 0xDD));
  const __m256i l8 = _mm256_castpd_si256(_mm256_permute4x64_pd(l, 0xD8)), h8 = _mm256_castpd_si256(_mm256_permute4x64_pd(h, 0xD8));
  std::memcpy(&lo, &l8, sizeof lo);
  std::memcpy(&hi, &h8, sizeof hi);
#else
  lo = gather(table, index);
  hi = gather(table, index + 1);
#endif
}

// floorf lane by lane for finite y.
inline f8 floor8(f8 y) {
#if defined(__AVX2__)
  __m256 v;
  std::memcpy(&v, &y, sizeof v);
  v = _mm256_round_ps(v, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
  std::memcpy(&y, &v, sizeof y);
  return y;
#else
  // |y| >= 2^23 is an integer already; below, truncate and step down where that rounded up. (A
  // zero's sign may differ from floorf's; nothing below sees it.)
  const f8 t = __builtin_convertvector(__builtin_convertvector(y, i8), f8);
  const f8 down = select(t > y, t - 1.0f, t);
  const f8 mag = as_f8(as_i8(y) & 0x7FFFFFFF);
  return select(mag >= 0x1p23f, y, down);
#endif
}

// table_power (walk_shared.h) in 8 lanes: the same integer and float operations per lane.
inline f8 power8(f8 x, float a, const int32_t* tables) {
  const i8 pos = x > 0.0f;
  const i8 b = as_i8(select(pos, x, splat(1.0f)));
  // table_log2
  const i8 e = (b >> 23) - 127;
  const i8 m = b & 0x7FFFFF;
  const i8 i = m >> (23 - kBits);
  const i8 f = m & ((1 << (23 - kBits)) - 1);
  i8 lo, hi;
  gather_pair(tables, i, lo, hi);
  const i8 frac = lo + (((hi - lo) * f) >> (23 - kBits));
  const f8 log2x = __builtin_convertvector(e, f8) + __builtin_convertvector(frac, f8) * 0x1p-24f;
  // table_exp2
  const f8 y = a * log2x;
  const f8 n = floor8(y);
  const f8 r = y - n;
  i8 fx = __builtin_convertvector(r * 0x1p24f, i8);
  fx = fx < (1 << 24) - 1 ? fx : (1 << 24) - 1;
  fx = fx > 0 ? fx : 0;  // only a non-finite y (never: exponents and pheromone are finite) is below
  const i8 j = fx >> (24 - kBits);
  const i8 g = fx & ((1 << (24 - kBits)) - 1);
  const int32_t* exp_table = tables + kTable;
  i8 elo, ehi;
  gather_pair(exp_table, j, elo, ehi);
  const i8 mant = elo + (((ehi - elo) * g) >> (24 - kBits));
  f8 clamped = select(n < -126.0f, splat(-126.0f), n);   // max_of(n, -126)
  clamped = select(127.0f < clamped, splat(127.0f), clamped);  // min_of(., 127)
  const i8 ni = __builtin_convertvector(clamped, i8);
  const f8 value = __builtin_convertvector(mant, f8) * 0x1p-23f * as_f8((ni + 127) << 23);
  const f8 result = select(n < -126.0f, splat(0.0f), select(n > 127.0f, splat(INFINITY), value));
  return select(pos, result, splat(0.0f));
}

// ---- one colony's walk ---------------------------------------------------------------------
class Colony {
  // A chunk's results of a step, on lines of their own: the cells its ants entered (2·cell +
  // diagonal) and its ants still walking.
  struct alignas(64) Chunk {
    std::vector<int32_t> entries, survivors;  // (A,) each, n_entries and n_survivors used
    int64_t n_entries = 0, n_survivors = 0;
  };

 public:
  Colony(const BacktrackInputs& in, const BacktrackOutputs& out, const BacktrackSizes& z)
      : in_(in), out_(out), N_(z.n_cells), A_(z.n_ants), D_(z.depth), exploit_(z.exploit), table_(z.table),
        n_chunks_(z.n_chunks) {
    const int64_t N = N_, A = A_, D = D_;
    const float* P = in.scalars;
    q0_ = P[0], alpha_ = P[1], beta_ = P[2], lo_ = P[3], hi_ = P[4], rho_ = P[5];
    keep_ = 1.0f - rho_;
    amount_[0] = P[6] / 1.0f;
    amount_[1] = P[6] / kSqrt2;
    offsets_ = i8{in.offsets[0], in.offsets[1], in.offsets[2], in.offsets[3],
                  in.offsets[4], in.offsets[5], in.offsets[6], in.offsets[7]};
    width_ = in.offsets[2];  // the move (1, 0) of jaco.moves.MOVES
    // The bits read around a cell reach width + 1 cells before it and after it, 8 bytes at a time.
    ant_bytes_ = ((N + 2 * width_ + 2 + 7) / 8 + 8 + 63) / 64 * 64;
    tabu_.assign(A * ant_bytes_ / 8 + 8, 0);
    tabu_base_ = reinterpret_cast<uint8_t*>(first_line(tabu_.data()));
    std::memcpy(out.tau, in.tau, N * sizeof(float));
    tau_power_.assign(N + 2 * width_ + 4, 0.0f);
    int64_t i = 0;
    for (; i + 8 <= N; i += 8) {  // 8 cells in a row: loaded and stored at once
      f8 x;
      std::memcpy(&x, out.tau + i, sizeof x);
      const f8 p = power8(x, alpha_, in.tables);
      std::memcpy(tau_power_.data() + padded(i), &p, sizeof p);
    }
    if (i < N) set_tau_powers(N - i, [&](int64_t k) { return int32_t(i + k); });
    ants_.assign(A, Ant{});
    // The cells entered in a step are counted in a hash table a few times larger than the ants.
    int bits = 6;
    while ((int64_t(1) << bits) < 4 * A) ++bits;
    hash_shift_ = 32 - bits;
    hash_mask_ = (uint32_t(1) << bits) - 1;
    slot_cell_.assign(size_t(1) << bits, -1);
    slot_index_.assign(size_t(1) << bits, 0);
    for (auto* v : {&touched_slot_, &touched_cell_, &touched_n1_, &touched_n2_}) v->assign(A + 8, 0);
    uniforms_.assign(A * 16 + 16, 0.0f);
    uniforms_base_ = first_line(uniforms_.data());
    chunks_.resize(n_chunks_);
    for (Chunk& chunk : chunks_) chunk.survivors.resize(A), chunk.entries.resize(A);
    walking_.resize(A);
    n_walking_ = 0;
    bounds_.resize(n_chunks_ + 1);
    for (int64_t a = 0; a < A; ++a) {
      ants_[a].cur = in.start;
      ants_[a].drawn = ~0u;
      set_tabu(a, in.start);
      out.stack[a * D] = in.start;
      out.moves[a * D] = -1;
      if (in.start != in.goal) walking_[n_walking_++] = int32_t(a);
    }
    split();
  }

  // Step t of chunk k's ants: every walking ant's weights first, then their moves.
  void step_chunk(int64_t k, int64_t t) {
    Chunk& chunk = chunks_[k];
    chunk.n_entries = chunk.n_survivors = 0;
    const int32_t* begin = walking_.data() + bounds_[k];
    const int32_t* end = walking_.data() + bounds_[k + 1];
    prefetch_rows(begin, end);
    for (const int32_t* a = begin; a < end; ++a) weigh(*a);
    for (const int32_t* a = begin; a < end; ++a)
      if (move(*a, t, chunk)) chunk.survivors[chunk.n_survivors++] = *a;
  }

  // On a large map the ants' rows are far from the cache, and each ant's weights wait on its
  // row: asked for together first, their loads overlap (a 256x256 map: 15 % of the walk).
  void prefetch_rows(const int32_t* begin, const int32_t* end) const {
    for (const int32_t* a = begin; a < end; ++a) __builtin_prefetch(in_.rows + int64_t(ants_[*a].cur) * 8);
  }

  // Chunk k's ants still walking after step t − 1, prepared for step t (prepare).
  void prepare_chunk(int64_t k, int64_t t) {
    const Chunk& chunk = chunks_[k];
    prefetch_rows(chunk.survivors.data(), chunk.survivors.data() + chunk.n_survivors);
    for (int64_t i = 0; i < chunk.n_survivors; ++i) prepare(chunk.survivors[i], t);
  }

  // Eqs. 4-2..4-4 on the cells entered in this step (jaco.planners.iaca.local_update); the ants
  // still walking after it (none: the walk is over, later steps would change nothing).
  int64_t update() {
    int64_t n_touched = 0;
    n_walking_ = 0;
    for (const Chunk& chunk : chunks_) {
      std::copy_n(chunk.survivors.data(), chunk.n_survivors, walking_.data() + n_walking_);
      n_walking_ += chunk.n_survivors;
      for (int64_t i = 0; i < chunk.n_entries; ++i) {
        const int32_t e = chunk.entries[i];  // 2·cell + diagonal
        const int32_t cell = e >> 1;
        uint32_t h = (uint32_t(cell) * 0x9E3779B1u) >> hash_shift_;
        while (slot_cell_[h] != cell && slot_cell_[h] >= 0) h = (h + 1) & hash_mask_;
        if (slot_cell_[h] < 0) {
          slot_cell_[h] = cell;
          slot_index_[h] = int32_t(n_touched);
          touched_slot_[n_touched] = int32_t(h);
          touched_cell_[n_touched++] = cell;
          __builtin_prefetch(out_.tau + cell);  // read below, 8 cells at a time
        }
        (e & 1 ? touched_n2_ : touched_n1_)[slot_index_[h]] += 1;
      }
    }
    // 8 cells at a time, each lane the scalar operations of local_update: the 8 cells' pheromone
    // is read at once, then τ^α of the new values. Lanes past the cells entered hold earlier
    // steps' cells (or cell 0) and are not stored.
    for (int64_t i = 0; i < n_touched; i += 8) {
      i8 cell, n1, n2;
      std::memcpy(&cell, touched_cell_.data() + i, sizeof cell);
      std::memcpy(&n1, touched_n1_.data() + i, sizeof n1);
      std::memcpy(&n2, touched_n2_.data() + i, sizeof n2);
      const i8 count = n1 + n2;
      const f8 deposit = __builtin_convertvector(n1, f8) * amount_[0] + __builtin_convertvector(n2, f8) * amount_[1];
      // jaco.planners.iaca.int_power(keep, count) per lane: a lane multiplies only at its own bits,
      // and squarings past a count's highest bit change nothing, so they stop at the lanes' highest.
      f8 decay = splat(1.0f), base = splat(keep_);
      int32_t top = 0;
      for (int k = 0; k < 8; ++k) top |= count[k];
      for (int bit = 0; bit < 16 && (top >> bit); ++bit) {
        decay = select(((count >> bit) & 1) != 0, decay * base, decay);
        base = base * base;
      }
      f8 mean_decay = splat(1.0f);
      if (rho_ > 1e-6f) {
        const f8 k_rho = __builtin_convertvector(count, f8) * rho_;
        mean_decay = (1.0f - decay) / select(k_rho < 1e-12f, splat(1e-12f), k_rho);  // std::max(kρ, 1e-12)
      }
      const f8 tau = as_f8(gather(out_.tau, cell));
      f8 v = decay * tau + deposit * mean_decay;
      v = select(v < lo_, splat(lo_), v);  // std::max(v, lo)
      v = select(hi_ < v, splat(hi_), v);  // std::min(v, hi)
      const f8 p = power8(v, alpha_, in_.tables);
      for (int64_t k = 0, n = std::min<int64_t>(8, n_touched - i); k < n; ++k) {
        out_.tau[cell[k]] = v[k];
        tau_power_[padded(cell[k])] = p[k];
      }
    }
    for (int64_t j = 0; j < n_touched; ++j) {
      slot_cell_[touched_slot_[j]] = -1;
      touched_n1_[j] = touched_n2_[j] = 0;
    }
    split();
    return n_walking_;
  }

  // The next step's chunks, in the ants' order (an ant seldom changes thread), equal shares.
  // The thread that publishes the step (chunk 0) updates the pheromone alone, while the others
  // prepare their ants for the next step; each thread's ants then cost about as much in its
  // chunk. (Before the others prepared, chunk 0 took 13/20 of the ants on two chunks: the others
  // start later and read the pheromone the first one just updated from its cache, not theirs.)
  void split() {
    const int64_t walking = n_walking_;
    for (int64_t k = 0; k <= n_chunks_; ++k) bounds_[k] = walking * k / n_chunks_;
  }

  // Final paths, visited cells and the cells of eq. (4-6) (jaco.planners.iaca.infeasible_cells).
  void finish() {
    const BacktrackOutputs& o = out_;
    // An ant's tabu bits are the cells it entered. As words: visited, their OR over the ants;
    // bad, the cells a failed ant entered or an arrived one entered off its final path; good,
    // the cells of an arrived ant's final path (a path's cells are distinct, all entered).
    const int64_t words = ant_bytes_ / 8;
    std::vector<uint64_t> visited(words, 0), bad(words, 0), good(words, 0);
    for (int64_t a = 0; a < A_; ++a) {
      int32_t* stack = o.stack + a * D_;
      const int32_t sp = o.sp[a] = ants_[a].sp;
      o.actions[a] = ants_[a].actions;
      const bool arrived = o.arrived[a] = ants_[a].cur == in_.goal;
      std::fill(stack + sp + 1, stack + D_, -1);
      std::fill(o.moves + a * D_ + sp + 1, o.moves + (a + 1) * D_, -1);
      uint64_t* tabu = reinterpret_cast<uint64_t*>(tabu_of(a));
      for (int64_t w = 0; w < words; ++w) visited[w] |= tabu[w];
      if (arrived)
        for (int32_t i = 0; i <= sp; ++i) {
          const int64_t at = padded(stack[i]);
          tabu[at >> 6] &= ~(uint64_t(1) << (at & 63));
          good[at >> 6] |= uint64_t(1) << (at & 63);
        }
      for (int64_t w = 0; w < words; ++w) bad[w] |= tabu[w];
    }
    for (int64_t i = 0; i < N_; ++i) {
      const int64_t at = padded(i);
      const uint64_t bit = uint64_t(1) << (at & 63);
      o.visited[i] = (visited[at >> 6] & bit) != 0;
      o.infeasible[i] = (bad[at >> 6] & ~good[at >> 6] & bit) != 0;
    }
  }

 private:
  // The first cache-line boundary at or after p (the vectors above hold 64 bytes to spare).
  template <typename T>
  static T* first_line(T* p) {
    return reinterpret_cast<T*>((reinterpret_cast<uintptr_t>(p) + 63) & ~uintptr_t(63));
  }

  // Where cell i is in the tables padded by width + 1 cells on each side (a tabu bitmap, τ^α), so
  // that the 3×3 neighbourhood of any cell is read without a bounds test.
  int64_t padded(int64_t cell) const { return width_ + 1 + cell; }

  // Ant a's tabu list: bit padded(i) of its bitmap is cell i.
  uint8_t* tabu_of(int64_t a) { return tabu_base_ + a * ant_bytes_; }
  void set_tabu(int64_t a, int32_t cell) {
    const int64_t at = padded(cell);
    tabu_of(a)[at >> 3] |= uint8_t(1u << (at & 7));
  }
  // The tabu bits of cell c's 3×3 neighbourhood, bit 3·(dr + 1) + dc + 1 for the cell
  // c + dr·width + dc: a row's 3 cells are 3 consecutive bits, read with one load.
  uint32_t tabu_around(int64_t a, int32_t c) {
    const uint8_t* bits = tabu_of(a);
    auto three = [&](int64_t at) {
      uint64_t word;
      std::memcpy(&word, bits + (at >> 3), sizeof word);
      return uint32_t(word >> (at & 7)) & 7u;
    };
    return three(c) | three(c + width_) << 3 | three(c + 2 * width_) << 6;  // bits of c − width − 1, ...
  }

  // τ^α of n ≤ 8 cells (cell_at(k), k < n) into tau_power_: power8 of the weights, once per cell
  // and pheromone value rather than once per ant and step (the same lanes, so the same bits).
  template <typename CellAt>
  void set_tau_powers(int64_t n, CellAt cell_at) {
    f8 x = splat(1.0f);
    for (int64_t k = 0; k < n; ++k) x[k] = out_.tau[cell_at(k)];
    const f8 p = power8(x, alpha_, in_.tables);
    for (int64_t k = 0; k < n; ++k) tau_power_[padded(cell_at(k))] = p[k];
  }

  // The uniform of ant a at step t (AntRng::at), from 8 Threefry blocks drawn at once.
  float uniform(int64_t a, int64_t t) {
    float* u = uniforms_base_ + a * 16;
    if (ants_[a].drawn != uint32_t(t >> 4)) {
      ants_[a].drawn = uint32_t(t >> 4);
      draw_blocks<u8, f8>(in_.k0, in_.k1, uint32_t(a), ants_[a].drawn * 8, u);
    }
    return u[t & 15];
  }

  // What ant a's next step weighs apart from the pheromone: its allowed moves (`allowed`, and how
  // many: returned) and, where it has a choice (two moves or more) of IACA's own heuristic, η^β
  // of eq. (4-5) over them (`eta_power`). None of it depends on the local update.
  int allowed_moves(int64_t a, i8& allowed, f8& eta_power) {
    const int32_t c = ants_[a].cur;
    f8 r;
    std::memcpy(&r, in_.rows + int64_t(c) * 8, sizeof r);
    const i8 on_map = r > 0.0f;  // rows are > 0 exactly on the moves the map allows
    // jaco.moves.MOVES: (−1, 0), (0, 1), (1, 0), (0, −1), (−1, 1), (1, 1), (1, −1), (−1, −1).
    const i8 move_bit = i8{1 << 1, 1 << 5, 1 << 7, 1 << 3, 1 << 2, 1 << 8, 1 << 6, 1 << 0};
    allowed = on_map & (((i8{} + int32_t(tabu_around(a, c))) & move_bit) == 0);
    const int n_allowed = __builtin_popcount(allowed_bits(allowed));
    if (n_allowed <= 1 || table_) return n_allowed;  // no powers: a step back, or the one move the roulette can pick
    const f8 rr = select(allowed, r, splat(0.0f));
    float total = rr[0];
    for (int k = 1; k < 8; ++k) total = total + rr[k];
    f8 eta = 1.0f - rr / std::max(total, 1e-12f);
    eta = select(eta < 1e-6f, splat(1e-6f), eta);  // std::max(eta, 1e-6f)
    eta_power = power8(eta, beta_, in_.tables);
    return n_allowed;
  }
  static uint32_t allowed_bits(i8 allowed) {  // bit k: move k allowed
#if defined(__AVX2__)
    __m256 mask;
    std::memcpy(&mask, &allowed, sizeof mask);
    return unsigned(_mm256_movemask_ps(mask));
#else
    uint32_t bits = 0;
    for (int k = 0; k < 8; ++k) bits |= uint32_t(allowed[k] != 0) << k;
    return bits;
#endif
  }

  // Ant a prepared for its step t (allowed_moves and its uniforms, into its record), so that the
  // step computes only what depends on the pheromone: a thread of a team prepares its ants while
  // another applies the local update.
  void prepare(int64_t a, int64_t t) {
    Ant& ant = ants_[a];
    i8 allowed;
    f8 eta_power{};  // set where it is read (a choice of two moves or more, no factor table)
    ant.n_allowed = allowed_moves(a, allowed, eta_power);
    ant.allowed = allowed_bits(allowed);
    if (ant.n_allowed >= 2 && !table_) std::memcpy(ant.w, &eta_power, sizeof eta_power);
    if (ant.n_allowed >= 1) uniform(a, t);
    ant.ready = 1;
  }

  // The weights of ant a's 8 moves (eq. 4-1), and how many are allowed, into ants_[a]: τ^α of
  // the cells around it as the pheromone is now, times η^β (or another planner's factor). Past
  // the one branch on the ant (no choice, no powers) the weights are branch-free, so the CPU
  // overlaps one ant's latencies with the next ant's.
  void weigh(int64_t a) {
    Ant& ant = ants_[a];
    i8 allowed;
    f8 eta_power{};  // set where it is read (a choice of two moves or more, no factor table)
    if (ant.ready) {  // prepared by a thread of the team
      ant.ready = 0;
      allowed = ((i8{} + int32_t(ant.allowed)) & i8{1, 2, 4, 8, 16, 32, 64, 128}) != 0;
      std::memcpy(&eta_power, ant.w, sizeof eta_power);
    } else {
      ant.n_allowed = allowed_moves(a, allowed, eta_power);
    }
    if (ant.n_allowed <= 1) {  // a step back, or the one move the roulette can pick
      const f8 w = select(allowed, splat(1.0f), splat(0.0f));
      std::memcpy(ant.w, &w, sizeof w);
      return;
    }
    const int32_t c = ant.cur;
    f8 v;  // τ^α of the 8 cells
#if defined(__AVX2__)
    const float* around = tau_power_.data() + c;  // around[0]: the cell c − width − 1
    // 4 cells of each row, from c − 1, arranged in the moves' order (as tabu_around).
    const __m128 above = _mm_loadu_ps(around), middle = _mm_loadu_ps(around + width_),
                 below = _mm_loadu_ps(around + 2 * width_);
    const __m256 rows_ab = _mm256_insertf128_ps(_mm256_castps128_ps256(above), below, 1);
    const __m256 diagonal = _mm256_permutevar8x32_ps(rows_ab, _mm256_setr_epi32(1, 0, 5, 0, 2, 6, 4, 0));
    const __m256 level = _mm256_permutevar8x32_ps(_mm256_castps128_ps256(middle), _mm256_setr_epi32(0, 2, 0, 0, 0, 0, 0, 0));
    const __m256 tp = _mm256_blend_ps(diagonal, level, 0x0A);  // moves 1 and 3 from the middle row
    std::memcpy(&v, &tp, sizeof v);
#else
    const i8 cells = allowed & (c + offsets_);  // not allowed: cell 0, never read for a move
    for (int k = 0; k < 8; ++k) v[k] = tau_power_[padded(cells[k])];
#endif
    if (table_) {  // another planner's factor, fixed for the iteration
      f8 factor;
      std::memcpy(&factor, in_.factors + int64_t(c) * 8, sizeof factor);
      v = v * factor;
    } else {  // eq. 4-5 over the ant's allowed moves
      v = v * eta_power;
    }
    v = select(v != v, splat(1e-30f), v);
    v = select(v < 1e-30f, splat(1e-30f), v);  // std::max(v, 1e-30f)
    v = select(1e30f < v, splat(1e30f), v);    // std::min(v, 1e30f)
    const f8 w = select(allowed, v, splat(0.0f));
    std::memcpy(ant.w, &w, sizeof w);
  }

  // Ant a's step t from its weights: forward by the roulette, else back along its path. Whether
  // the ant still walks after it.
  bool move(int64_t a, int64_t t, Chunk& chunk) {
    Ant& ant = ants_[a];
    int32_t* stack = out_.stack + a * D_;
    if (ant.n_allowed == 0) {
      if (ant.sp == 0) return false;  // back at the start with nothing left: dead
      ant.sp -= 1;  // step back along the path; the dead end stays tabu
      ant.cur = stack[ant.sp];
      ant.actions += 1;
      return true;
    }
    const int k = choose(ant.w, uniform(a, t), q0_, exploit_);
    const int32_t next = ant.cur + in_.offsets[k];
    ant.cur = next;
    ant.sp += 1;
    stack[ant.sp] = next;
    out_.moves[a * D_ + ant.sp] = k;
    set_tabu(a, next);
    ant.actions += 1;
    chunk.entries[chunk.n_entries++] = 2 * next + (k >= 4);
    return next != in_.goal;
  }

  BacktrackInputs in_;
  BacktrackOutputs out_;
  int64_t N_, A_, D_;
  bool exploit_, table_;
  int64_t n_chunks_;
  float q0_, alpha_, beta_, lo_, hi_, rho_, keep_, amount_[2];
  i8 offsets_;
  // Tabu lists as bits, one bitmap per ant in the cells' order (rows of the map one after
  // another), so that the 3 cells of a row around the ant are read together; an ant's bitmap is
  // written only by the thread walking it, and starts on a cache line of its own.
  int64_t width_, ant_bytes_;
  std::vector<uint64_t> tabu_;  // (A, ant_bytes / 8) from tabu_base_, the first cache line in it
  uint8_t* tabu_base_;
  std::vector<float> tau_power_;  // (width + 1 + N + width + 3,): τ^α of cell i at width + 1 + i, as the pheromone is now
  // The hash table of the cells entered in this step: the cell of a slot (-1: empty) and its
  // index in the touched_ arrays.
  std::vector<int32_t> slot_cell_, slot_index_;
  // The cells entered in this step, in the order first entered: slot, cell, straight and diagonal entries.
  std::vector<int32_t> touched_slot_, touched_cell_, touched_n1_, touched_n2_;
  int hash_shift_;
  uint32_t hash_mask_;
  // What the step changes of an ant, on a cache line of its own: the threads of a team walk
  // neighbouring ants, and a line written by both would go back and forth between their cores.
  struct alignas(64) Ant {
    float w[8];  // the weights of the ant's 8 moves this step, 0 where not allowed (η^β when prepared)
    int32_t n_allowed = 0;
    uint32_t allowed = 0;  // bit k: move k allowed
    int32_t ready = 0;     // prepared for its next step
    int32_t cur = 0, sp = 0, actions = 0;  // its cell, the top of its stack, its steps
    uint32_t drawn = 0;  // its uniforms are those of steps 16·drawn .. 16·drawn + 15
  };
  std::vector<Ant> ants_;
  std::vector<Chunk> chunks_;
  std::vector<int32_t> walking_;  // the ants walking in this step, in order: n_walking_ of them
  int64_t n_walking_;
  std::vector<int64_t> bounds_;   // chunk k walks walking_[bounds[k]] .. walking_[bounds[k + 1] − 1]
  std::vector<float> uniforms_;   // (A, 16) from uniforms_base_: each ant's uniforms, a line an ant
  float* uniforms_base_;
};

}  // namespace

const BacktrackKernel JACO_CAT(backtrack_, JACO_ISA) = {
    [](const BacktrackInputs& in, const BacktrackOutputs& out, const BacktrackSizes& sizes) -> void* {
      return new Colony(in, out, sizes);
    },
    [](void* colony, int64_t chunk, int64_t t) { static_cast<Colony*>(colony)->step_chunk(chunk, t); },
    [](void* colony, int64_t chunk, int64_t t) { static_cast<Colony*>(colony)->prepare_chunk(chunk, t); },
    [](void* colony) { return static_cast<Colony*>(colony)->update(); },
    [](void* colony) {
      static_cast<Colony*>(colony)->finish();
      delete static_cast<Colony*>(colony);
    },
};
