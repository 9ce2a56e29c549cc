// IACA's backtracking walk alone, several builds of it in one program (bench_iaca_kernel.py).
//
// Each variant is jaco/planners/iaca_lanes.cc of one revision, compiled with JACO_ISA=<name> so
// that its table of entry points is backtrack_<name>; VARIANTS lists them as X(name) X(name) ...
// The program walks one colony with each variant in turn, walk after walk, so that every variant
// sees the machine's slow and fast moments alike, and prints per variant the median and best time
// of a walk, the forward and back steps of a walk, and a hash of what the walks left (pheromone,
// stacks, steps): the same hash means the same walks.
//
// usage: iaca_kernel_driver DIR WALKS   (DIR holds the inputs bench_iaca_kernel.py wrote)
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "iaca_lanes.h"

#define X(v) extern const BacktrackKernel backtrack_##v;
VARIANTS
#undef X
#define X(v) &backtrack_##v,
const BacktrackKernel* const kVariants[] = {VARIANTS};
#undef X
#define X(v) #v,
const char* const kNames[] = {VARIANTS};
#undef X
constexpr int kCount = sizeof(kVariants) / sizeof(kVariants[0]);

template <typename T>
std::vector<T> load(const std::string& path, size_t n) {
  std::vector<T> v(n);
  FILE* f = std::fopen(path.c_str(), "rb");
  if (!f || std::fread(v.data(), sizeof(T), n, f) != n) {
    std::fprintf(stderr, "cannot read %zu values from %s\n", n, path.c_str());
    std::exit(1);
  }
  std::fclose(f);
  return v;
}

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: %s DIR WALKS\n", argv[0]);
    return 2;
  }
  const std::string dir = std::string(argv[1]) + "/";
  const int walks = std::atoi(argv[2]);
  // sizes: cells, ants, step limit; then start, goal, exploit (0/1)
  const auto sizes = load<int64_t>(dir + "sizes.bin", 6);
  const int64_t N = sizes[0], A = sizes[1], S = sizes[2], D = S + 1;
  const auto tau = load<float>(dir + "tau.bin", N);
  const auto rows = load<float>(dir + "rows.bin", N * 8);
  const auto scalars = load<float>(dir + "scalars.bin", 7);
  const auto offsets = load<int32_t>(dir + "offsets.bin", 8);
  const auto tables = load<int32_t>(dir + "tables.bin", 2 * 1025);
  std::vector<float> factors(N * 8, 0.0f), tau_out(N);
  std::vector<int32_t> stack(A * D), moves(A * D), sp(A), actions(A);
  std::vector<uint8_t> arrived(A), visited(N), infeasible(N);
  std::vector<std::vector<double>> seconds(kCount);
  std::vector<uint64_t> hash(kCount, 1469598103934665603ull);
  int64_t steps = 0;
  for (int w = 0; w < walks; ++w)
    for (int v = 0; v < kCount; ++v) {
      const BacktrackKernel& kernel = *kVariants[v];
      // Each walk its own key, the same for every variant.
      const BacktrackInputs in{tau.data(), rows.data(), factors.data(), scalars.data(), offsets.data(),
                               tables.data(), uint32_t(12345 + w), 678u, int32_t(sizes[3]), int32_t(sizes[4])};
      const BacktrackOutputs out{tau_out.data(), stack.data(), sp.data(), actions.data(), moves.data(),
                                 reinterpret_cast<bool*>(arrived.data()), reinterpret_cast<bool*>(visited.data()),
                                 reinterpret_cast<bool*>(infeasible.data())};
      const auto t0 = std::chrono::steady_clock::now();
      void* colony = kernel.make(in, out, BacktrackSizes{N, A, D, S, 1, sizes[5] != 0, false});
      for (int64_t t = 0, walking = A; t < S && walking > 0; ++t) {
        kernel.step_chunk(colony, 0, t);
        walking = kernel.update(colony);
      }
      kernel.finish(colony);
      seconds[v].push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
      auto mix = [&](uint32_t x) { hash[v] = (hash[v] ^ x) * 1099511628211ull; };
      for (int64_t a = 0; a < A; ++a) {
        mix(uint32_t(sp[a])), mix(uint32_t(actions[a])), mix(arrived[a]);
        for (int64_t i = 0; i <= sp[a]; ++i) mix(uint32_t(stack[a * D + i])), mix(uint32_t(moves[a * D + i]));
        if (v == 0) steps += actions[a];
      }
      for (int64_t i = 0; i < N; ++i) {
        uint32_t bits;
        std::memcpy(&bits, &tau_out[i], sizeof bits);
        mix(bits), mix(visited[i]), mix(infeasible[i]);
      }
    }
  for (int v = 0; v < kCount; ++v) {
    std::vector<double>& s = seconds[v];
    std::sort(s.begin(), s.end());
    std::printf("RESULT %s %.6f %.6f %lld %016llx\n", kNames[v], s[s.size() / 2], s[0],
                static_cast<long long>(steps / walks), static_cast<unsigned long long>(hash[v]));
  }
  return 0;
}
