// read_input_file / check_input_file (input_file.hpp): stat the path and refuse anything but a
// regular file without opening it, then open without blocking (a FIFO's open would wait for a
// writer), fstat the descriptor (what was opened may have been swapped in), then read it whole. POSIX calls, because std::ifstream can neither open without blocking nor say what it
// opened.
#include "pliant/input_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include <fmt/format.h>

#include "pliant/error.hpp"

namespace pliant {
namespace {

// What a file that is not regular is, for the message.
const char* kind_of(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// An open descriptor of a regular file, closed on scope exit.
class RegularFile {
 public:
  RegularFile(const std::filesystem::path& path, std::string_view what) {
    const std::string p = path.string();
    // What the path names (links followed), before opening it: a FIFO or a device is refused
    // without being opened at all (opening a FIFO is seen by its writer; a tape rewinds...).
    struct stat named {};
    if (::stat(p.c_str(), &named) != 0)
      throw InputError(fmt::format("{}: cannot open {} ({})", p, what, std::strerror(errno)));
    refuse_unless_regular(p, what, named.st_mode);
    // Then open without blocking and check again what was opened (it may have been swapped).
    fd_ = ::open(p.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
    if (fd_ < 0) {
      const int e = errno;
      if (e == EISDIR) throw InputError(fmt::format("{}: is a directory, not a {}", p, what));
      throw InputError(fmt::format("{}: cannot open {} ({})", p, what, std::strerror(e)));
    }
    struct stat st {};
    if (::fstat(fd_, &st) != 0) {
      const int e = errno;
      ::close(fd_);
      throw InputError(fmt::format("{}: cannot open {} ({})", p, what, std::strerror(e)));
    }
    if (!S_ISREG(st.st_mode)) {
      ::close(fd_);
      refuse_unless_regular(p, what, st.st_mode);
    }
    size_ = std::uintmax_t(st.st_size);
  }
  static void refuse_unless_regular(const std::string& p, std::string_view what, mode_t mode) {
    if (S_ISREG(mode)) return;
    if (S_ISDIR(mode)) throw InputError(fmt::format("{}: is a directory, not a {}", p, what));
    throw InputError(fmt::format("{}: is {}, not a regular file: a {} must be a regular file", p, kind_of(mode), what));
  }
  ~RegularFile() { ::close(fd_); }
  RegularFile(const RegularFile&) = delete;
  RegularFile& operator=(const RegularFile&) = delete;
  int fd() const { return fd_; }
  std::uintmax_t size() const { return size_; }

 private:
  int fd_ = -1;
  std::uintmax_t size_ = 0;
};

}  // namespace

std::uintmax_t check_input_file(const std::filesystem::path& path, std::string_view what) {
  return RegularFile(path, what).size();
}

std::string read_input_file(const std::filesystem::path& path, std::string_view what) {
  const RegularFile file(path, what);
  std::string text;
  text.reserve(std::size_t(file.size()));
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(file.fd(), buf, sizeof buf);
    if (n == 0) break;
    if (n < 0) {
      if (errno == EINTR) continue;
      throw InputError(fmt::format("{}: cannot read {} ({})", path.string(), what, std::strerror(errno)));
    }
    text.append(buf, std::size_t(n));
  }
  return text;
}

}  // namespace pliant
