// The pheromone copied into the deposit's result and checked for what an add of +0.0 would change
// (pheromone.cc says why), in one branch-free pass that the compiler vectorises: setup.py compiles
// this file once per instruction set (JACO_ISA), so the pass runs as wide as the walk's lanes.
// Every set copies and compares the same floats: the same result.
#include <cstdint>
#include <cstring>

#include "pheromone_lanes.h"

#ifndef JACO_ISA
#define JACO_ISA baseline
#endif
#define JACO_CAT2(a, b) a##b
#define JACO_CAT(a, b) JACO_CAT2(a, b)

bool JACO_CAT(copy_and_check_zero_adds_, JACO_ISA)(const float* src, float* dst, int64_t M) {
  uint32_t odd = 0;
  for (int64_t i = 0; i < M; ++i) {
    uint32_t bits;
    std::memcpy(&bits, src + i, 4);
    odd |= uint32_t(bits == 0x80000000u) | uint32_t((bits & 0x7fffffffu) > 0x7f800000u);
    dst[i] = src[i];
  }
  return odd == 0;
}
