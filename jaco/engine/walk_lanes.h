// The dying-ant walk of a group of colonies with their ants in one pool of SIMD lanes
// (walk_lanes.cc), and the instruction sets it is built for. walk.cc chooses one at run time (jaco_set_isa), never one
// the CPU lacks.
#pragma once

#include <cstdint>

// One colony's walk: its inputs and where its results go (the slices of the FFI buffers).
struct LaneColony {
  const float* weights;   // (N, 8) move weights, 0 exactly on the moves not allowed
  const int32_t* offsets;  // (8,) cell offset of each move
  int32_t start, goal, n_cells;
  float q0;
  uint32_t k0, k1;        // the iteration's key words
  int64_t n_ants, steplimit;
  int64_t ant_begin, ant_end;  // the ants this call walks (the colony's ants may be split between threads)
  bool exploit;
  int32_t* edges;         // (S, A), S = steplimit: from·8 + move of each step, 8N where no step
                          // (the cells entered follow from it: jaco.engine.native.walk); on entry
                          // the last walks' edges, each column its steps and then 8N
  int32_t* n_steps;       // (A,)
  int32_t* n_diagonal;    // (A,)
  bool* arrived;          // (A,)
  bool* visited;          // (N,): the cells this call's ants visited
  uint32_t* tabu;         // (N,) scratch of the thread (P·N with P tabu planes), all zero on entry and
                          // on return; valid from tabu[-pad] to its last word + pad, pad = width + 2
                          // (the rows above the first and below the last, always zero)
  int32_t tabu_planes;    // 0: the ant of lane l has bit l of tabu[cell], cleared along its path when
                          // it stops. P > 0: ant a (counted from ant_begin) has bit a % 32 of plane
                          // a / 32 (P planes of n·N words one after another, n the group's colonies),
                          // so an ant that stops clears nothing; once the group's walks end, one
                          // scan of the planes gives the cells visited and zeroes them
  int32_t width;          // row length when the offsets are jaco.moves.MOVES on a grid of that width
                          // (at least 3), so a cell's 3x3 neighbourhood is 3 runs of 3 cells;
                          // 0 otherwise (each neighbour is looked up on its own)
};

// The instruction sets, widest last. Each walk_lanes_<isa> is the same source compiled with that
// set's flags (setup.py); JACO_HAVE_<ISA> says which were built.
#define JACO_ISA_LIST(X) X(baseline) X(avx2) X(avx512)
// walk_lanes_<isa>(colonies, n) walks n colonies' ants in one pool of lanes: a lane whose ant stops
// takes the next ant, of the same colony or of the next, so the lanes idle only at the group's
// end. For n > 1 the colonies are consecutive slices of one call: they share n_cells, offsets,
// n_ants, steplimit and exploit, walk all their ants, and colony j's weights, edges and visited
// cells lie j·N·8, j·S·A and j·N elements after colony 0's; colonies[0].tabu is the group's
// scratch, n·N cells (P·n·N with tabu planes, plus the pads), and the other colonies' tabu is not
// read.
#define JACO_DECLARE_WALK(isa) void walk_lanes_##isa(const LaneColony* colonies, int64_t n_colonies);
JACO_ISA_LIST(JACO_DECLARE_WALK)
#undef JACO_DECLARE_WALK
