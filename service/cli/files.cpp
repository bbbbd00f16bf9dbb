#include "service/cli/files.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <system_error>

namespace softgrasp::cli {
namespace {

using core::ErrorCode;
using core::MakeError;

core::Error SystemError(const std::string& what, const std::filesystem::path& path, int error) {
  const ErrorCode code =
      error == ENOENT || error == ENOTDIR ? ErrorCode::kNotFound : ErrorCode::kUnprocessable;
  return MakeError(code,
                   what + " " + path.string() + ": " + std::generic_category().message(error));
}

/// Closes `fd` on every path out of a scope.
class Descriptor {
 public:
  explicit Descriptor(int fd) : fd_(fd) {}
  Descriptor(const Descriptor&) = delete;
  Descriptor& operator=(const Descriptor&) = delete;
  ~Descriptor() {
    if (fd_ >= 0) ::close(fd_);
  }
  int get() const { return fd_; }
  /// Closes now and reports close()'s error (0 when none).
  int Close() {
    const int result = ::close(fd_);
    fd_ = -1;
    return result == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

/// Creates a fresh temporary file beside `path`: its descriptor and name, or errno.
int CreateTemporary(const std::filesystem::path& path, std::filesystem::path* temporary) {
  static std::atomic<unsigned> counter{0};
  for (int attempt = 0; attempt < 100; ++attempt) {
    *temporary = path.parent_path() /
                 ("." + path.filename().string() + ".tmp-" + std::to_string(::getpid()) + "-" +
                  std::to_string(counter.fetch_add(1)));
    const int fd = ::open(temporary->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) return -errno;
  }
  return -EEXIST;
}

/// Writes all of `bytes`, flushes them to the disk and takes `like`'s permissions if it exists;
/// returns errno, 0 when all went well.
int Fill(int fd, std::string_view bytes, const std::filesystem::path& like) {
  while (!bytes.empty()) {
    const ssize_t n = ::write(fd, bytes.data(), bytes.size());
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return errno;
    bytes.remove_prefix(static_cast<std::size_t>(n));
  }
  struct stat existing {};
  if (::stat(like.c_str(), &existing) == 0 && S_ISREG(existing.st_mode) &&
      ::fchmod(fd, existing.st_mode & 07777) != 0) {
    return errno;
  }
  return ::fdatasync(fd) == 0 ? 0 : errno;
}

}  // namespace

core::Result<std::string> ReadFile(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return SystemError("cannot read", path, errno);
  Descriptor file(fd);
  struct stat info {};
  if (::fstat(fd, &info) != 0) return SystemError("cannot read", path, errno);
  if (S_ISDIR(info.st_mode)) return SystemError("cannot read", path, EISDIR);
  std::string bytes;
  if (S_ISREG(info.st_mode)) bytes.reserve(static_cast<std::size_t>(info.st_size));
  char buffer[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return SystemError("cannot read", path, errno);
    if (n == 0) break;
    bytes.append(buffer, static_cast<std::size_t>(n));
  }
  return bytes;
}

std::optional<core::Error> WriteFile(const std::filesystem::path& path, std::string_view bytes,
                                     Parents parents) {
  const std::string name = path.filename().string();
  if (name.empty() || name == "." || name == "..") {
    return MakeError(ErrorCode::kInvalidArgument,
                     "cannot write " + path.string() + ": not a file name");
  }
  const std::filesystem::path folder = path.parent_path();
  if (parents == Parents::kCreate && !folder.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(folder, ec);
    // A file where a folder should be: "Not a directory" says it better than "File exists".
    if (ec)
      return SystemError("cannot create", folder, ec.value() == EEXIST ? ENOTDIR : ec.value());
  }
  std::filesystem::path temporary;
  const int fd = CreateTemporary(path, &temporary);
  if (fd < 0) return SystemError("cannot write", path, -fd);
  Descriptor file(fd);
  int error = Fill(fd, bytes, path);
  const int close_error = file.Close();
  if (error == 0) error = close_error;
  if (error == 0 && ::rename(temporary.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(temporary.c_str());
    return SystemError("cannot write", path, error);
  }
  return std::nullopt;
}

}  // namespace softgrasp::cli
