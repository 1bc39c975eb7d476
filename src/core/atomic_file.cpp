// Write-to-temporary-then-rename, so a failed or interrupted run leaves no half-written output.
#include "core/atomic_file.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <filesystem>

#include "dsmplan/core.hpp"

namespace dsmplan {

namespace {

// The temporary files being written, where a signal handler can read them: fixed slots of C
// strings (a handler may not allocate or lock), each free, being filled, or ready.
constexpr int kSlots = 256;
constexpr size_t kPathBytes = 4096;
char temp_paths[kSlots][kPathBytes];
std::atomic<int> slot_state[kSlots];  // 0 free, 1 being filled, 2 ready
constexpr int kFree = 0, kFilling = 1, kReady = 2;

// Takes a slot for a mkstemp pattern, so that mkstemp fills in the name where the handler reads
// it: a signal between creating the file and remembering it would otherwise leave it behind.
// Before mkstemp the handler unlinks a name that does not exist, which is harmless.
int remember(const std::string& pattern) {
  if (pattern.size() >= kPathBytes) return -1;
  for (int i = 0; i < kSlots; ++i) {
    int expected = kFree;
    if (!slot_state[i].compare_exchange_strong(expected, kFilling)) continue;
    std::memcpy(temp_paths[i], pattern.c_str(), pattern.size() + 1);
    slot_state[i].store(kReady);
    return i;
  }
  return -1;  // more than 256 outputs at once: this one is not removed on a signal
}

void forget(int slot) {
  if (slot >= 0) slot_state[slot].store(kFree);
}

// While a SignalsHeld lives, a signal is kept here and acted on when the last one ends.
std::atomic<int> holds{0};
std::atomic<int> held_signal{0};

void remove_temporaries_and_exit_now(int signal) {
  for (int i = 0; i < kSlots; ++i)
    if (slot_state[i].load() == kReady) ::unlink(temp_paths[i]);
  ::_exit(128 + signal);
}

extern "C" void remove_temporaries_and_exit(int signal) {
  if (holds.load() > 0) {
    int none = 0;
    held_signal.compare_exchange_strong(none, signal);
    return;
  }
  remove_temporaries_and_exit_now(signal);
}

}  // namespace

void remove_partial_outputs_on_signals() {
  struct sigaction action {};
  action.sa_handler = remove_temporaries_and_exit;
  sigemptyset(&action.sa_mask);
  for (int signal : {SIGINT, SIGTERM, SIGHUP}) ::sigaction(signal, &action, nullptr);
}

SignalsHeld::SignalsHeld() { holds.fetch_add(1); }

SignalsHeld::~SignalsHeld() {
  if (holds.fetch_sub(1) == 1)
    if (const int signal = held_signal.exchange(0); signal != 0) remove_temporaries_and_exit_now(signal);
}

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  namespace fs = std::filesystem;
  // A NUL byte would cut the name where the system reads it: another file would be written.
  if (path_.find('\0') != std::string::npos)
    throw OutputError(path_.substr(0, path_.find('\0')) + "\\0...", "a file name with a NUL byte");
  const fs::path target(path_);
  if (target.filename().empty()) throw OutputError(path_, "not a file name");
  std::error_code ec;
  if (fs::is_directory(target, ec)) throw OutputError(path_, "is a directory");
  // A device, pipe or socket cannot be replaced by renaming (and must not be: as root, /dev/full
  // would become a regular file); a whole-file writer can only refuse it.
  if (fs::exists(target, ec) && !fs::is_regular_file(target, ec))
    throw OutputError(path_,
                      "cannot write: not a regular file (a device, pipe or socket); outputs are written to a "
                      "temporary file and renamed into place");
  fs::path folder = target.parent_path();
  if (folder.empty()) folder = ".";
  std::string pattern = (folder / ("." + target.filename().string() + ".partial-XXXXXX")).string();
  slot_ = remember(pattern);
  char* name = slot_ >= 0 ? temp_paths[slot_] : pattern.data();
  int fd = ::mkstemp(name);
  if (fd < 0) {
    forget(slot_);
    throw OutputError(path_, std::string("cannot write: ") + std::strerror(errno));
  }
  temp_path_ = name;
  stream_ = ::fdopen(fd, "w+b");  // + : a writer may read back what it wrote (PlyStreamWriter)
  if (!stream_) {
    ::close(fd);
    ::unlink(temp_path_.c_str());
    forget(slot_);
    throw OutputError(path_, std::string("cannot write: ") + std::strerror(errno));
  }
  std::setvbuf(stream_, nullptr, _IOFBF, 1 << 20);
}

AtomicFile::~AtomicFile() {
  if (stream_) std::fclose(stream_);
  if (!committed_) ::unlink(temp_path_.c_str());
  forget(slot_);
}

void AtomicFile::close_stream() {
  if (stream_ && std::fclose(stream_) != 0) {
    stream_ = nullptr;
    fail(std::strerror(errno));
  }
  stream_ = nullptr;
}

void AtomicFile::fail(const std::string& why) {
  if (stream_) std::fclose(stream_);
  stream_ = nullptr;
  ::unlink(temp_path_.c_str());
  committed_ = true;  // nothing left to clean up
  throw OutputError(path_, "cannot write: " + why);
}

void AtomicFile::write(const void* data, size_t bytes) {
  if (bytes && std::fwrite(data, 1, bytes, stream_) != bytes) fail(std::strerror(errno));
}

void AtomicFile::commit() {
  if (stream_) {
    if (std::fflush(stream_) != 0) fail(std::strerror(errno));
    close_stream();
  }
  // mkstemp creates 0600; give the output the permissions a normal file would get.
  mode_t mask = ::umask(0);
  ::umask(mask);
  ::chmod(temp_path_.c_str(), 0666 & ~mask);
  if (std::rename(temp_path_.c_str(), path_.c_str()) != 0) fail(std::strerror(errno));
  committed_ = true;
}

}  // namespace dsmplan
