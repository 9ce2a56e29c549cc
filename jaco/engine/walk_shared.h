// Pieces shared by the kernels of walk.cc, walk_lanes.cc and jaco/planners/iaca.cc: the counter-based uniforms, the
// roulette and the table powers, each doing exactly the float operations of its JAX definition.
//
// Include it *inside* a namespace of internal linkage (an anonymous one): walk_lanes.cc is compiled
// once per instruction set (baseline, AVX2, AVX-512), and an inline function shared between those
// objects could be emitted once with AVX-512 instructions and then called by the baseline code,
// which must run on every CPU. Needs <cstdint>, <cstring> and <math.h> included before.

constexpr float kSqrt2 = static_cast<float>(1.4142135623730951);  // float32(hypot(1, 1)): a diagonal step

// The bits of x as a To (C++20's std::bit_cast): a float vector as ints and back, for selects
// that keep a float's bits.
template <typename To, typename From>
inline To bits_as(From x) {
  static_assert(sizeof(To) == sizeof(From), "same size");
  To y;
  std::memcpy(&y, &x, sizeof y);
  return y;
}

// std::min and std::max as the standard defines them (NaN: the first argument), of internal
// linkage here: a template instance of std:: is shared between the objects (see above).
template <typename T>
inline T min_of(T a, T b) { return b < a ? b : a; }
template <typename T>
inline T max_of(T a, T b) { return a < b ? b : a; }

// ---- counter-based uniforms ----------------------------------------------------------------
inline uint32_t rotl(uint32_t x, int r) { return (x << r) | (x >> (32 - r)); }

// Threefry-2x32, 20 rounds (Salmon et al. 2011), as jax.extend.random.threefry2x32_p.
inline void threefry(uint32_t k0, uint32_t k1, uint32_t& x0, uint32_t& x1) {
  const uint32_t ks[3] = {k0, k1, k0 ^ k1 ^ 0x1BD11BDAu};
  static const int rot[2][4] = {{13, 15, 26, 6}, {17, 29, 16, 24}};
  x0 += ks[0];
  x1 += ks[1];
  for (int i = 0; i < 5; ++i) {
    for (int j = 0; j < 4; ++j) {
      x0 += x1;
      x1 = rotl(x1, rot[i % 2][j]);
      x1 ^= x0;
    }
    x0 += ks[(i + 1) % 3];
    x1 += ks[(i + 2) % 3] + uint32_t(i + 1);
  }
}

inline float unit_float(uint32_t bits) {
  const uint32_t b = (bits >> 9) | 0x3F800000u;
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f - 1.0f;
}

// The uniforms of one ant: step s uses word s % 2 of Threefry(key; ant, s / 2).
struct AntRng {
  uint32_t k0, k1, ant;
  uint32_t block = 0xFFFFFFFFu;
  uint32_t words[2] = {0, 0};
  float at(uint32_t step) {
    if ((step >> 1) != block) {
      block = step >> 1;
      words[0] = ant;
      words[1] = block;
      threefry(k0, k1, words[0], words[1]);
    }
    return unit_float(words[step & 1]);
  }
};

// The uniforms of steps 2·block0 .. 2·block0 + 2L − 1 of one ant, as AntRng::at, for L blocks at
// once (block0 + l in lane l of VU, a vector of L uint32; VF of L floats).
template <typename VU, typename VF>
inline void draw_blocks(uint32_t k0, uint32_t k1, uint32_t ant, uint32_t block0, float* out) {
  constexpr int L = sizeof(VU) / sizeof(uint32_t);
  const uint32_t ks[3] = {k0, k1, k0 ^ k1 ^ 0x1BD11BDAu};
  VU x1 = {};
  for (int l = 0; l < L; ++l) x1[l] = uint32_t(l);  // a constant: block0 is added to it whole
  x1 += block0;
  VU x0 = x1 - x1 + (ant + ks[0]);
  x1 += ks[1];
#define JACO_MIX(r)        \
  x0 += x1;                \
  x1 = (x1 << r) | (x1 >> (32 - r)); \
  x1 ^= x0;
#define JACO_ROUND(a, b, c, d, i) \
  JACO_MIX(a) JACO_MIX(b) JACO_MIX(c) JACO_MIX(d) x0 += ks[(i + 1) % 3]; x1 += ks[(i + 2) % 3] + uint32_t(i + 1);
  JACO_ROUND(13, 15, 26, 6, 0)
  JACO_ROUND(17, 29, 16, 24, 1)
  JACO_ROUND(13, 15, 26, 6, 2)
  JACO_ROUND(17, 29, 16, 24, 3)
  JACO_ROUND(13, 15, 26, 6, 4)
#undef JACO_ROUND
#undef JACO_MIX
  const VU one = (x0 - x0) + 0x3F800000u;
  VF f0, f1;
  const VU b0 = (x0 >> 9) | one, b1 = (x1 >> 9) | one;
  std::memcpy(&f0, &b0, sizeof f0);
  std::memcpy(&f1, &b1, sizeof f1);
  f0 -= 1.0f;  // unit_float
  f1 -= 1.0f;
  for (int l = 0; l < L; ++l) {
    out[2 * l] = f0[l];
    out[2 * l + 1] = f1[l];
  }
}

// ---- the roulette (jaco.engine.walk.choose) --------------------------------------------------
inline int choose(const float* w, float u, float q0, bool exploit) {
  float c[8];
  c[0] = w[0];
  for (int k = 1; k < 8; ++k) c[k] = c[k - 1] + w[k];
  const float total = c[7];
  if (exploit) {
    if (u < q0) {  // the argmax; ties to the lowest index
      int best = 0;
      for (int k = 1; k < 8; ++k)
        if (w[k] > w[best]) best = k;
      return best;
    }
    u = (u - q0) / max_of(1.0f - q0, 1e-12f);
  }
  // The largest float below total (std::nextafter(total, 0) for a positive total, without the call).
  uint32_t tb;
  std::memcpy(&tb, &total, sizeof tb);
  tb -= 1;
  float below;
  std::memcpy(&below, &tb, sizeof below);
  const float x = min_of(u * total, below);
  int k = 0;
  for (int i = 0; i < 8; ++i) k += (c[i] <= x);
  return k;
}

// ---- powers from tables (jaco.engine.bitexact) ----------------------------------------------------
constexpr int kBits = 10;
constexpr int kTable = (1 << kBits) + 1;

inline float bits_float(int32_t b) {
  float f;
  std::memcpy(&f, &b, sizeof f);
  return f;
}

inline float table_log2(float x, const int32_t* log_table) {
  int32_t b;
  std::memcpy(&b, &x, sizeof b);
  const int32_t e = (b >> 23) - 127;
  const int32_t m = b & 0x7FFFFF;
  const int32_t i = m >> (23 - kBits);
  const int32_t f = m & ((1 << (23 - kBits)) - 1);
  const int32_t lo = log_table[i], hi = log_table[i + 1];
  const int32_t frac = lo + (((hi - lo) * f) >> (23 - kBits));
  return float(e) + float(frac) * 0x1p-24f;
}

inline float table_exp2(float y, const int32_t* exp_table) {
  const float n = floorf(y)  /* libm, not an inline C++ overload */;
  const float r = y - n;
  const int32_t fx = min_of(int32_t(r * 0x1p24f), (1 << 24) - 1);
  const int32_t j = fx >> (24 - kBits);
  const int32_t g = fx & ((1 << (24 - kBits)) - 1);
  const int32_t lo = exp_table[j], hi = exp_table[j + 1];
  const int32_t mant = lo + (((hi - lo) * g) >> (24 - kBits));
  const int32_t ni = int32_t(min_of(max_of(n, -126.0f), 127.0f));
  const float value = float(mant) * 0x1p-23f * bits_float((ni + 127) << 23);
  return n < -126.0f ? 0.0f : (n > 127.0f ? INFINITY : value);
}

inline float table_power(float x, float a, const int32_t* tables) {
  if (!(x > 0.0f)) return 0.0f;
  return table_exp2(a * table_log2(x, tables), tables + kTable);
}
