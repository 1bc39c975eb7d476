// The bounded mode as an OpenMPI task farm (master/worker; see "MPI" in dsmplan/tools.hpp).
// Blocks are independent by construction (simplify.hpp, "out of core"), so the farm only moves
// block indices out and blocks back; rank 0 numbers and writes them in order, as one process
// would.
#include "dsmplan/mpi_farm.hpp"

#include <mpi.h>

#include <chrono>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <map>
#include <thread>

#include "dsmplan/tools.hpp"

namespace dsmplan {

namespace {

enum Tag : int { work = 1, stop = 2, result = 3, failure = 4 };

// A block as bytes: index, valid cells, the error's five figures, then each tile's corners.
template <typename T>
void put(std::vector<char>& out, const T* data, size_t count) {
  const size_t at = out.size();
  out.resize(at + count * sizeof(T));
  if (count) std::memcpy(out.data() + at, data, count * sizeof(T));
}

std::vector<char> pack(const BoundedBlock& block) {
  std::vector<char> out;
  const uint64_t head[5] = {block.index, block.valid_cells, block.error.cells, block.error.uncovered,
                            block.tiles.size()};
  const double error[3] = {block.error.max_above, block.error.max_below, block.error.rms};
  put(out, head, 5);
  put(out, error, 3);
  for (const BoundedTile& tile : block.tiles) {
    const uint64_t n = tile.cols.size();
    put(out, &n, 1);
    put(out, tile.cols.data(), n);
    put(out, tile.rows.data(), n);
    put(out, tile.heights.data(), n);
  }
  return out;
}

class Reader {
public:
  explicit Reader(const std::vector<char>& bytes) : bytes_(bytes) {}
  template <typename T>
  void get(T* data, size_t count) {
    if (count > (bytes_.size() - at_) / sizeof(T)) throw Error("MPI: a worker's block message is truncated");
    if (count) std::memcpy(data, bytes_.data() + at_, count * sizeof(T));
    at_ += count * sizeof(T);
  }

private:
  const std::vector<char>& bytes_;
  size_t at_ = 0;
};

BoundedBlock unpack(const std::vector<char>& bytes) {
  Reader in(bytes);
  uint64_t head[5];
  double error[3];
  in.get(head, 5);
  in.get(error, 3);
  BoundedBlock block;
  block.index = head[0];
  block.valid_cells = head[1];
  block.error.cells = head[2];
  block.error.uncovered = head[3];
  block.error.max_above = error[0];
  block.error.max_below = error[1];
  block.error.rms = error[2];
  block.tiles.resize(head[4]);
  for (BoundedTile& tile : block.tiles) {
    uint64_t n;
    in.get(&n, 1);
    if (n > bytes.size()) throw Error("MPI: a worker's block message is damaged");
    tile.cols.resize(n);
    tile.rows.resize(n);
    tile.heights.resize(n);
    in.get(tile.cols.data(), n);
    in.get(tile.rows.data(), n);
    in.get(tile.heights.data(), n);
  }
  return block;
}

// The next message from any worker. Polled: a blocking receive spins in OpenMPI and would take
// a core from the workers on the same machine.
std::vector<char> receive_any(MPI_Status& status) {
  int arrived = 0;
  while (!arrived) {
    MPI_Iprobe(MPI_ANY_SOURCE, MPI_ANY_TAG, MPI_COMM_WORLD, &arrived, &status);
    if (!arrived) std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  int bytes = 0;
  MPI_Get_count(&status, MPI_BYTE, &bytes);
  std::vector<char> buffer(static_cast<size_t>(bytes));
  MPI_Recv(buffer.data(), bytes, MPI_BYTE, status.MPI_SOURCE, status.MPI_TAG, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return buffer;
}

int launched_ranks() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "PMI_SIZE"})
    if (const char* value = std::getenv(name)) return std::atoi(value);
  return 1;
}

}  // namespace

MpiFarm::MpiFarm(int& argc, char**& argv) {
  if (launched_ranks() < 2) return;
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
  MPI_Comm_size(MPI_COMM_WORLD, &size_);
  if (size_ < 2) MPI_Finalize();
}

MpiFarm::~MpiFarm() {
  if (active()) MPI_Finalize();
}

BoundedEngine MpiFarm::master() const {
  const int ranks = size_;
  return [ranks](GridSource& dsm, const BoundedSimplifyOptions& options, MeshSink& sink, const Progress& progress) {
    const Grid& frame = dsm.frame();
    const BoundedLayout layout = bounded_layout(frame.width, frame.height, options);
    BoundedAssembler assembler(frame, layout, sink);
    BoundedStreamResult out;
    out.blocks = layout.blocks();
    std::map<size_t, BoundedBlock> waiting;  // arrived ahead of their turn
    size_t next_to_send = 0, next_to_add = 0;
    int in_flight = 0;
    auto send_work = [&](int worker) {
      const int64_t index = static_cast<int64_t>(next_to_send++);
      MPI_Send(&index, 1, MPI_INT64_T, worker, Tag::work, MPI_COMM_WORLD);
      ++in_flight;
    };
    try {
      report(progress, 0);
      // Two blocks a worker: one to make, one queued, so no worker waits for rank 0.
      for (int round = 0; round < 2; ++round)
        for (int worker = 1; worker < ranks && next_to_send < layout.blocks(); ++worker) send_work(worker);
      while (next_to_add < layout.blocks()) {
        MPI_Status status;
        const std::vector<char> message = receive_any(status);
        --in_flight;
        if (status.MPI_TAG == Tag::failure) throw Error(std::string(message.begin(), message.end()));
        BoundedBlock block = unpack(message);
        if (next_to_send < layout.blocks()) send_work(status.MPI_SOURCE);
        waiting.emplace(block.index, std::move(block));
        for (auto it = waiting.find(next_to_add); it != waiting.end(); it = waiting.find(next_to_add)) {
          assembler.add(it->second);
          out.error.merge(it->second.error);
          out.valid_cells += it->second.valid_cells;
          waiting.erase(it);
          ++next_to_add;
          report(progress, double(next_to_add) / double(layout.blocks()));
        }
      }
    } catch (...) {
      // Workers still sending blocks must be heard out, or their sends would never complete.
      MPI_Status status;
      while (in_flight-- > 0) receive_any(status);
      throw;
    }
    if (out.valid_cells == 0) throw ArgumentError("DSM", "has no valid cell");
    out.vertices = assembler.vertices();
    out.triangles = assembler.triangles();
    return out;
  };
}

void MpiFarm::serve(const SimplifyJobOptions& options) const {
  std::unique_ptr<GridSource> dsm;  // opened at the first block: rank 0 may not farm at all
  BoundedLayout layout;
  // Resolved as rank 0 resolves them (max_error and conservative): every block made alike.
  const BoundedSimplifyOptions bounded = options.bounded_options();
  for (;;) {
    int64_t index = 0;
    MPI_Status status;
    MPI_Recv(&index, 1, MPI_INT64_T, 0, MPI_ANY_TAG, MPI_COMM_WORLD, &status);
    if (status.MPI_TAG == Tag::stop) return;
    std::vector<char> reply;
    int tag = Tag::result;
    try {
      if (!dsm) {
        dsm = open_raster(options.input, options.read);
        layout = bounded_layout(dsm->frame().width, dsm->frame().height, bounded);
      }
      reply = pack(simplify_bounded_block(*dsm, layout, static_cast<size_t>(index), bounded));
      if (reply.size() > static_cast<size_t>(std::numeric_limits<int>::max()))
        throw ArgumentError("--block-tiles", "a block exceeds one MPI message (2 GB); use fewer tiles a block");
    } catch (const std::exception& error) {
      const std::string what = error.what();
      reply.assign(what.begin(), what.end());
      tag = Tag::failure;
    }
    MPI_Send(reply.data(), static_cast<int>(reply.size()), MPI_BYTE, 0, tag, MPI_COMM_WORLD);
  }
}

void MpiFarm::release_workers() const {
  const int64_t none = -1;
  for (int worker = 1; worker < size_; ++worker) MPI_Send(&none, 1, MPI_INT64_T, worker, Tag::stop, MPI_COMM_WORLD);
}

}  // namespace dsmplan
