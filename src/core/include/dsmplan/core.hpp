// dsmplan/core.hpp: what every stage shares: errors, progress, coordinate reference.
//
// Errors. Every failure the library reports is a dsmplan::Error (a std::runtime_error) whose
// what() is one line of the form "FILE: PLACE: PROBLEM" (file and place omitted when they do
// not apply), ready to print as it is. The subclasses say whose fault it is:
//   InputError   - an input file is missing, unreadable or says something impossible;
//   ArgumentError - an option has a value the operation cannot work with;
//   OutputError  - an output cannot be written (nothing is left behind: outputs are written to a
//                  temporary file in the same folder and renamed into place only when complete).
// Functions never crash or hang on bad input; they throw one of these.
//
// Progress. Long operations take a Progress callback, called with the fraction done in [0, 1]
// (monotonic, the last call with exactly 1). Returning false asks the operation to stop: it then
// throws Cancelled. An empty callback costs nothing.
#pragma once

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace dsmplan {

class Error : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

/// Formats "file: place: problem", leaving out empty parts.
std::string located_message(const std::string& file, const std::string& place, const std::string& problem);

class InputError : public Error {
public:
  InputError(const std::string& file, const std::string& place, const std::string& problem)
      : Error(located_message(file, place, problem)) {}
};

/// What an input path must be before a reader opens it: InputError naming `path` when it exists
/// but is not a regular file (a FIFO, whose open() waits forever for a writer; a character
/// device such as /dev/zero, which never ends; a directory; a block device; a socket), or when
/// `max_bytes` > 0 and the file is larger (the size cap of a text format read whole, `what`
/// naming it: "a CAMERAS.json"), or when the name holds a NUL byte (the system would read the
/// name cut there: another file). A missing path passes: the reader says so. Opens nothing
/// (stat()). Every reader of dsmplan calls it first.
void require_input_file(const std::string& path, uint64_t max_bytes = 0, const char* what = nullptr);

/// `field` names what is wrong as the function's caller knows it: an options struct's field
/// ("max_agl", "pixels_per_cell"), a parameter ("path", "mesh"); the tools' jobs, which take the
/// command line's options, name the flag ("--max-agl"). The CLI shows a field as its flag.
class ArgumentError : public Error {
public:
  ArgumentError(const std::string& field, const std::string& problem)
      : Error(located_message("", field, problem)), field_(field), problem_(problem) {}
  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }

private:
  std::string field_, problem_;
};

/// A well-formed option value that the data refuse: a mission's home under a roof or inside a
/// zone, a landing outside the DSM. An InputError (the data's fault: exit 1, HTTP 422) that
/// still names the option's `field` as ArgumentError does, so every face names it as it names
/// the option (the CLI its flag, the service its key, Python its keyword). `nearest`: where the
/// value would be accepted (x, y, z in the data's CRS), when one was found.
class DataFault : public InputError {
public:
  DataFault(const std::string& field, const std::string& problem,
            std::optional<std::array<double, 3>> nearest = std::nullopt)
      : InputError("", field, problem), field_(field), problem_(problem), nearest_(nearest) {}
  const std::string& field() const { return field_; }
  const std::string& problem() const { return problem_; }
  const std::optional<std::array<double, 3>>& nearest() const { return nearest_; }

private:
  std::string field_, problem_;
  std::optional<std::array<double, 3>> nearest_;
};

class OutputError : public Error {
public:
  OutputError(const std::string& file, const std::string& problem) : Error(located_message(file, "", problem)) {}
};

/// Thrown when a Progress callback asked to stop. `stage` says what was stopped ("planning",
/// "naming the nearest valid point"), as in_stage() adds it; empty when no stage said.
class Cancelled : public Error {
public:
  explicit Cancelled(std::string stage = {})
      : Error(stage.empty() ? "cancelled" : "cancelled while " + stage), stage_(std::move(stage)) {}
  const std::string& stage() const { return stage_; }

private:
  std::string stage_;
};

/// Runs `work()`; a Cancelled without a stage that it throws is thrown again naming `stage`
/// (the innermost stage named wins).
template <typename Work>
auto in_stage(const char* stage, Work&& work) -> decltype(work()) {
  try {
    return work();
  } catch (const Cancelled& cancelled) {
    if (!cancelled.stage().empty()) throw;
    throw Cancelled(stage);
  }
}

/// Choices. An option whose value is one of a list (a planner, a format, a restriction) is
/// checked by require_choice() on every face, so a typo is refused with the nearest name rather
/// than read as another choice or as none.
/// The name among `names` nearest `typed` when near enough to be a typo: the same but for case,
/// else at most a third of its letters (at least one) changed; empty otherwise.
std::string nearest_name(const std::string& typed, const std::vector<std::string>& names);
/// "a, b or c".
std::string choice_list(const std::vector<std::string>& names);
/// ArgumentError(field, "must be A, B or C, got 'x' (did you mean A?)") unless `value` is one of
/// `names` (exact, case-sensitive: the names are what files and other tools write).
void require_choice(const std::string& field, const std::string& value, const std::vector<std::string>& names);

/// Stopping a request. A request that may be given up on (a service's time budget, Ctrl-C in
/// Python) carries a StopToken: whoever gives up calls request_stop(), or the token's deadline
/// passes; every search the request starts (the planners through their validity checker, the
/// refusals' nearest-point search, snapping, the zones) calls check() between its steps, which
/// throws Cancelled. Thread-safe; check() costs an atomic load and, with a deadline, a clock read.
class StopToken {
public:
  using Clock = std::chrono::steady_clock;
  StopToken() = default;
  explicit StopToken(Clock::time_point deadline) : deadline_(deadline) {}
  /// Stops at `deadline` or when `parent` stops (a part's own time limit within a whole's).
  StopToken(Clock::time_point deadline, std::shared_ptr<const StopToken> parent)
      : deadline_(deadline), parent_(std::move(parent)) {}
  void request_stop() noexcept { stopped_.store(true, std::memory_order_relaxed); }
  bool stop_requested() const noexcept {
    return stopped_.load(std::memory_order_relaxed) ||
           (deadline_ != Clock::time_point::max() && Clock::now() >= deadline_) ||
           (parent_ && parent_->stop_requested());
  }
  /// Throws Cancelled when a stop was requested or the deadline passed.
  void check() const {
    if (stop_requested()) throw Cancelled();
  }

private:
  std::atomic<bool> stopped_{false};
  Clock::time_point deadline_ = Clock::time_point::max();
  std::shared_ptr<const StopToken> parent_;
};

/// check() when there is a token.
inline void check_stop(const StopToken* stop) {
  if (stop) stop->check();
}

/// Fraction done in [0, 1]; return false to cancel.
using Progress = std::function<bool(double fraction)>;

/// Reports `fraction` through `progress` (if any) and throws Cancelled when asked to stop.
void report(const Progress& progress, double fraction);

/// The part [begin, end] of a parent's progress, for a sub-step of a longer operation.
Progress sub_progress(const Progress& parent, double begin, double end);

/// Memory. Before a large allocation (a raster's cells, a point cloud, a mesh) the readers and
/// jobs estimate the bytes they will need and call require_memory(), so that an input too big for
/// the machine is refused with the figure instead of being killed by the kernel part-way.
/// The machine's memory: physical memory, or the cgroup's limit, the process's address-space
/// limit (ulimit -v) or the environment's DSMPLAN_MAX_MEMORY (bytes, or with K, M, G, T in
/// binary steps: "4G") when that is lower. A DSMPLAN_MAX_MEMORY that is not such a size is an
/// ArgumentError naming it.
double machine_memory_bytes();
/// "3.6 TB", "23 GB", "512 bytes" (binary steps, as free(1) counts).
std::string format_bytes(double bytes);
/// "needs about X of memory, this machine has Y" when `bytes` exceeds machine_memory_bytes(),
/// else empty. A double, so that absurd declared sizes cannot overflow on the way here.
std::string memory_problem(double bytes);
/// Throws InputError(file, place, memory_problem(bytes)) when that is not empty.
void require_memory(const std::string& file, const std::string& place, double bytes);

/// Installs handlers of SIGINT, SIGTERM and SIGHUP that remove the temporary file of every
/// output being written and exit with 128 + the signal (130, 143, 129): an interrupted run
/// leaves nothing behind (outputs are written to a temporary file and renamed into place when
/// whole). For programs such as the dsmplan binary; a library does not take a process's signals.
void remove_partial_outputs_on_signals();

/// While one lives, those handlers keep a signal instead of acting on it, and act when the last
/// one ends (the outputs committed by then stay): a set of outputs that must be replaced together
/// (plan --routes' folder) is replaced whole. Hold them only over work that ends by itself, in
/// seconds; without those handlers installed it does nothing.
class SignalsHeld {
public:
  SignalsHeld();
  ~SignalsHeld();
  SignalsHeld(const SignalsHeld&) = delete;
  SignalsHeld& operator=(const SignalsHeld&) = delete;
};

/// A coordinate reference system as the data declared it. The core only carries it along;
/// the I/O layer (GDAL/PROJ) resolves `definition` into the descriptive fields.
using Point3 = std::array<double, 3>;  ///< x, y, z

struct Crs {
  std::string definition;     ///< WKT, PROJJSON or "EPSG:n" as found or given; empty = unknown
  std::string name;           ///< e.g. "ETRS89 / UTM zone 32N" (filled by the I/O layer)
  int epsg = 0;               ///< horizontal EPSG code, 0 when there is none
  std::string wkt;            ///< single-line WKT2 (filled by the I/O layer)
  std::string vertical_name;  ///< vertical datum/CRS name, empty when not known
  std::string vertical_unit;  ///< e.g. "metre", empty when not known
  bool geographic = false;    ///< x,y are angles (longitude, latitude), not lengths
  /// Units, as the CRS (and a raster band's unit type) declare them; dsmplan measures in
  /// metres and refuses anything else (see metric_problem() in raster.hpp). Filled by the I/O layer.
  std::string linear_unit;     ///< horizontal unit, e.g. "metre", "US survey foot"; empty when not known
  double linear_unit_m = 0;    ///< metres per horizontal unit (1 for metres); 0 unknown or geographic
  double vertical_unit_m = 0;  ///< metres per vertical unit of `vertical_unit`; 0 unknown

  bool known() const { return !definition.empty() || !wkt.empty(); }
};

}  // namespace dsmplan
