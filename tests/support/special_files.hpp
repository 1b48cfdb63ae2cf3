// Files that are not regular files, for the tests that every reader refuses them (input_file.hpp):
// a FIFO (whose open blocks until a writer comes) and a symbolic link to /dev/zero (endless
// zeros). A reader that still opened them would hang or read until memory runs out, so the
// FIFO comes with a writer thread that opens it, writes nothing and closes it as soon as a
// reader appears (or after 2 s): a broken reader then sees an empty file instead of hanging,
// and opened() tells that it opened the FIFO at all (pliant refuses it without opening it).
// Header-only; include it from any test folder.
#pragma once
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <thread>

namespace pliant::special {

class Fifo {
 public:
  explicit Fifo(std::filesystem::path path) : path_(std::move(path)) {
    std::filesystem::remove(path_);
    if (::mkfifo(path_.c_str(), 0600) != 0) throw std::runtime_error("mkfifo " + path_.string());
    writer_ = std::thread([this] {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
      while (!stop_ && std::chrono::steady_clock::now() < deadline) {
        const int fd = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK);  // succeeds once a reader has it open
        if (fd >= 0) {
          opened_ = true;
          ::close(fd);
          return;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
  }
  ~Fifo() {
    stop_ = true;
    writer_.join();
    std::filesystem::remove(path_);
  }
  const std::filesystem::path& path() const { return path_; }
  // True once a reader had the FIFO open. Settles within 5 ms of that reader's open.
  bool opened() const {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return opened_;
  }

 private:
  std::filesystem::path path_;
  std::atomic<bool> stop_{false}, opened_{false};
  std::thread writer_;
};

// A symbolic link named `path` to /dev/zero.
inline std::filesystem::path link_to_dev_zero(const std::filesystem::path& path) {
  std::filesystem::remove(path);
  std::filesystem::create_symlink("/dev/zero", path);
  return path;
}

}  // namespace pliant::special
