// dsmplan/mpi_farm.hpp: the bounded simplification as an MPI task farm (`mpirun -np N dsmplan simplify`).
#pragma once

#include "dsmplan/tools.hpp"

namespace dsmplan {

// ---- MPI: the bounded mode as a task farm -------------------------------------------------
//
// `mpirun -np N dsmplan simplify DSM --max-error E ... -o MESH.ply` runs the streamed bounded
// mode as a task farm: rank 0 hands out blocks (their indices), ranks 1..N-1 open the DSM
// themselves, make the blocks they are given (simplify_bounded_block(), on their threads) and
// send them back; rank 0 assembles them in order and writes the mesh. The mesh is the same, bit
// for bit, as a run without mpirun (blocks do not depend on where they are made, and only rank
// 0 numbers them). Rank 0 keeps at most two blocks a worker in flight, so its memory stays
// bounded too. Other commands run on rank 0 alone. Built when CMake finds MPI (DSMPLAN_MPI).

class MpiFarm {
public:
  /// Starts MPI when this process was launched by mpirun with two or more ranks (and dsmplan
  /// was built with MPI); otherwise the farm is inactive and MPI is not touched.
  MpiFarm(int& argc, char**& argv);
  ~MpiFarm();  ///< MPI_Finalize
  MpiFarm(const MpiFarm&) = delete;
  MpiFarm& operator=(const MpiFarm&) = delete;

  bool active() const { return size_ > 1; }
  int rank() const { return rank_; }
  int size() const { return size_; }

  /// Rank 0: the engine to put into SimplifyJobOptions::bounded_engine.
  BoundedEngine master() const;
  /// Ranks >= 1: opens `options.input` and makes blocks until rank 0 says stop. A failure is
  /// sent to rank 0, which reports it.
  void serve(const SimplifyJobOptions& options) const;
  /// Rank 0, once its job is over (done or failed): releases the workers still waiting.
  void release_workers() const;

private:
  int rank_ = 0, size_ = 1;
};

}  // namespace dsmplan
