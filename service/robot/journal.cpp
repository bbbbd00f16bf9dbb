#include "service/robot/journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>

namespace softgrasp::robot {
namespace {

using core::ErrorCode;
using core::MakeError;

constexpr std::size_t kCrcDigits = 8;

std::array<std::uint32_t, 256> MakeCrcTable() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t n = 0; n < 256; ++n) {
    std::uint32_t c = n;
    for (int k = 0; k < 8; ++k) c = (c & 1U) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
    table[n] = c;
  }
  return table;
}

core::Error SystemError(const std::string& what, int error_number) {
  return MakeError(ErrorCode::kInternal, what + ": " + std::strerror(error_number), "journal_dir");
}

int HexValue(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

// Makes a new directory entry durable: fsync of the folder that holds it.
void SyncDirectory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;  // best effort: the records themselves are still fdatasync'ed
  (void)::fsync(fd);
  ::close(fd);
}

core::Result<std::string> ReadAll(int fd, const std::string& path) {
  std::string bytes;
  char buffer[65536];
  if (::lseek(fd, 0, SEEK_SET) < 0) return SystemError("lseek " + path, errno);
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return SystemError("read " + path, errno);
    if (n == 0) return bytes;
    bytes.append(buffer, static_cast<std::size_t>(n));
  }
}

}  // namespace

std::uint32_t Crc32(std::string_view bytes) {
  static const std::array<std::uint32_t, 256> kTable = MakeCrcTable();
  std::uint32_t c = 0xFFFFFFFFU;
  for (const char ch : bytes) c = kTable[(c ^ static_cast<unsigned char>(ch)) & 0xFFU] ^ (c >> 8);
  return c ^ 0xFFFFFFFFU;
}

std::string EncodeJournalLine(std::string_view payload) {
  char crc[kCrcDigits + 1];
  std::snprintf(crc, sizeof crc, "%08x", Crc32(payload));
  std::string line(crc, kCrcDigits);
  line.push_back(' ');
  line.append(payload);
  return line;
}

core::Result<std::string> DecodeJournalLine(std::string_view line) {
  if (line.size() < kCrcDigits + 1 || line[kCrcDigits] != ' ') {
    return MakeError(ErrorCode::kUnprocessable, "no checksum prefix");
  }
  std::uint32_t expected = 0;
  for (std::size_t i = 0; i < kCrcDigits; ++i) {
    const int v = HexValue(line[i]);
    if (v < 0) return MakeError(ErrorCode::kUnprocessable, "checksum is not lower-case hex");
    expected = (expected << 4) | static_cast<std::uint32_t>(v);
  }
  const std::string_view payload = line.substr(kCrcDigits + 1);
  if (Crc32(payload) != expected) {
    return MakeError(ErrorCode::kUnprocessable, "checksum mismatch");
  }
  return std::string(payload);
}

std::vector<std::string> ParseJournal(std::string_view bytes, JournalReport* report,
                                      std::size_t* complete_bytes) {
  std::vector<std::string> payloads;
  std::size_t start = 0;
  std::int64_t line_number = 0;
  while (start < bytes.size()) {
    const std::size_t end = bytes.find('\n', start);
    ++line_number;
    if (end == std::string_view::npos) {
      // A last line without its newline was being written when the process died.
      report->torn_tail = true;
      report->torn_tail_bytes = static_cast<std::int64_t>(bytes.size() - start);
      report->warnings.push_back("line " + std::to_string(line_number) +
                                 ": incomplete last line (" + std::to_string(bytes.size() - start) +
                                 " bytes, a write cut short); skipped");
      break;
    }
    auto payload = DecodeJournalLine(bytes.substr(start, end - start));
    if (payload) {
      payloads.push_back(std::move(payload).value());
      ++report->good_records;
    } else {
      ++report->corrupt_lines;
      report->warnings.push_back("line " + std::to_string(line_number) + ": " +
                                 payload.error().message + "; skipped");
    }
    start = end + 1;
  }
  *complete_bytes = report->torn_tail ? start : bytes.size();
  return payloads;
}

core::Result<Journal::Opened> Journal::Open(const std::string& dir) {
  namespace fs = std::filesystem;
  if (dir.empty()) {
    return MakeError(ErrorCode::kInvalidArgument, "the journal folder is not set", "journal_dir");
  }
  std::error_code error;
  const bool created = fs::create_directories(dir, error);
  if (error) {
    return MakeError(ErrorCode::kInternal,
                     "cannot create the journal folder " + dir + ": " + error.message(),
                     "journal_dir");
  }
  if (created) fs::permissions(dir, fs::perms::owner_all, error);  // commands are nobody's business
  const fs::path path = fs::path(dir) / kJournalFileName;
  const bool existed = fs::exists(path, error);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  if (fd < 0) return SystemError("open " + path.string(), errno);
  std::unique_ptr<Journal> journal(new Journal(fd, path.string()));
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e == EWOULDBLOCK) {
      return MakeError(ErrorCode::kConflict,
                       "the journal " + path.string() +
                           " is in use by another softgrasp-server; give each its own "
                           "robot.journal_dir",
                       "journal_dir");
    }
    return SystemError("flock " + path.string(), e);
  }
  if (!existed) SyncDirectory(dir);

  auto bytes = ReadAll(fd, path.string());
  if (!bytes) return bytes.error();
  Opened opened;
  std::size_t complete_bytes = 0;
  opened.payloads = ParseJournal(bytes.value(), &opened.report, &complete_bytes);
  if (opened.report.torn_tail) {
    if (::ftruncate(fd, static_cast<off_t>(complete_bytes)) != 0 || ::fdatasync(fd) != 0) {
      return SystemError("cutting the torn last line off " + path.string(), errno);
    }
  }
  opened.journal = std::move(journal);
  return opened;
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);  // also releases the lock
}

core::Result<Ok> Journal::Append(std::string_view payload) {
  if (payload.find('\n') != std::string_view::npos) {
    throw std::invalid_argument("Journal::Append: payload must not contain a newline");
  }
  std::string line = EncodeJournalLine(payload);
  line.push_back('\n');
  std::lock_guard<std::mutex> lock(mutex_);
  const off_t before = ::lseek(fd_, 0, SEEK_END);
  if (before < 0) return SystemError("lseek " + path_, errno);
  std::size_t written = 0;
  while (written < line.size()) {
    const ssize_t n = ::write(fd_, line.data() + written, line.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : EIO;
      // Cut a partial record off so that the next one starts on a line of its own.
      (void)::ftruncate(fd_, before);
      return SystemError("write " + path_, e);
    }
    written += static_cast<std::size_t>(n);
  }
  if (::fdatasync(fd_) != 0) {
    const int e = errno;
    (void)::ftruncate(fd_, before);
    return SystemError("fdatasync " + path_, e);
  }
  return Ok{};
}

}  // namespace softgrasp::robot
