// IACA's backtracking walk of one colony (iaca_lanes.cc), built once per instruction set like the
// dying-ant walk's lanes (walk_lanes.h); iaca.cc runs it on XLA's threads and picks the set the
// dying-ant walk uses (jaco_isa_get).
#pragma once

#include <cstdint>

#include "walk_lanes.h"

struct BacktrackInputs {  // one colony's slices of the FFI buffers
  const float *tau, *rows, *factors, *scalars;  // scalars: q0, alpha, beta, lo, hi, rho_local, q
  const int32_t *offsets, *tables;
  uint32_t k0, k1;
  int32_t start, goal;
};

struct BacktrackOutputs {
  float* tau;
  int32_t *stack, *sp, *actions, *moves;  // moves: (A, D) as stack, the move that entered each cell
  bool *arrived, *visited, *infeasible;
};

struct BacktrackSizes {
  int64_t n_cells, n_ants, depth, steplimit;
  int64_t n_chunks;  // the ants are walked in this many chunks, each step (by one or several threads)
  bool exploit, table;
};

// One colony's walk, step by step: make, then for t = 0, 1, ...: step_chunk for every chunk
// (any threads, any order), then update (one thread; it returns the ants still walking: when none,
// the walk is over); then finish.
struct BacktrackKernel {
  void* (*make)(const BacktrackInputs&, const BacktrackOutputs&, const BacktrackSizes&);
  void (*step_chunk)(void* colony, int64_t chunk, int64_t t);
  // Chunk k's ants still walking after its step t − 1, prepared for step t (what a step computes
  // apart from the pheromone); any thread, while update runs, before step t.
  void (*prepare_chunk)(void* colony, int64_t chunk, int64_t t);
  int64_t (*update)(void* colony);
  void (*finish)(void* colony);  // and frees it
};

#define JACO_DECLARE_BACKTRACK(isa) extern const BacktrackKernel backtrack_##isa;
JACO_ISA_LIST(JACO_DECLARE_BACKTRACK)
#undef JACO_DECLARE_BACKTRACK
