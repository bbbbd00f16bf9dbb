#include "service/robot/journal.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <utility>

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

// Makes directory entries (a new file, a rename) durable: fsync of the folder that holds them.
// 0, or the errno of what failed.
int SyncDirectory(const std::filesystem::path& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return errno;
  const int result = ::fsync(fd) == 0 ? 0 : errno;
  ::close(fd);
  return result;
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

// Bytes [begin, end) of the file; fewer when the file is shorter.
core::Result<std::string> ReadRange(int fd, std::int64_t begin, std::int64_t end,
                                    const std::string& path) {
  std::string bytes(static_cast<std::size_t>(std::max<std::int64_t>(end - begin, 0)), '\0');
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::pread(fd, bytes.data() + done, bytes.size() - done,
                              static_cast<off_t>(begin + static_cast<std::int64_t>(done)));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return SystemError("read " + path, errno);
    if (n == 0) break;
    done += static_cast<std::size_t>(n);
  }
  bytes.resize(done);
  return bytes;
}

// 0, or the errno of the failed write.
int WriteAll(int fd, std::string_view bytes) {
  std::size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : EIO;
    written += static_cast<std::size_t>(n);
  }
  return 0;
}

// Copies the good lines of `bytes` (complete lines read from file offset `base`) to `out`, asking
// `keep` about those that start before `decided_bytes`. Counts every complete line in
// `*records_seen` and the copied ones in `*records_kept`.
void CopyKeptLines(std::string_view bytes, std::int64_t base, std::int64_t decided_bytes,
                   const std::function<bool(std::string_view)>& keep, std::string* out,
                   std::int64_t* records_seen, std::int64_t* records_kept) {
  std::size_t start = 0;
  while (start < bytes.size()) {
    const std::size_t end = bytes.find('\n', start);
    if (end == std::string_view::npos) break;  // not a complete line: never part of the journal
    const std::string_view line = bytes.substr(start, end - start);
    ++*records_seen;
    const auto payload = DecodeJournalLine(line);
    const bool decided = base + static_cast<std::int64_t>(start) < decided_bytes;
    if (payload && (!decided || keep(payload.value()))) {
      out->append(line);
      out->push_back('\n');
      ++*records_kept;
    }
    start = end + 1;
  }
}

// The compaction's temporary file: closed and removed unless released (after the rename).
class TempFile {
 public:
  TempFile(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  ~TempFile() {
    if (fd_ < 0) return;
    ::close(fd_);
    (void)::unlink(path_.c_str());
  }
  TempFile(const TempFile&) = delete;
  TempFile& operator=(const TempFile&) = delete;
  int fd() const { return fd_; }
  int Release() { return std::exchange(fd_, -1); }

 private:
  int fd_;
  std::string path_;
};

core::Error Conflict(const std::string& path) {
  return MakeError(ErrorCode::kConflict,
                   "the journal " + path +
                       " is in use by another softgrasp-server; give each its own "
                       "robot.journal_dir",
                   "journal_dir");
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
  const fs::path lock_path = fs::path(dir) / kJournalLockFileName;
  const fs::path temp_path = fs::path(dir) / kJournalTempFileName;
  // The lock lives in a file of its own: a compaction renames a new journal file over the old one,
  // and a lock on the journal file would stay with the old one.
  bool entries_changed = !fs::exists(lock_path, error);
  const int lock_fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
  if (lock_fd < 0) return SystemError("open " + lock_path.string(), errno);
  std::unique_ptr<Journal> journal(new Journal(lock_fd, dir, path.string()));
  if (::flock(lock_fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e == EWOULDBLOCK) return Conflict(path.string());
    return SystemError("flock " + lock_path.string(), e);
  }

  Opened opened;
  if (::unlink(temp_path.c_str()) == 0) {
    entries_changed = true;
    opened.report.removed_temp_file = true;
    opened.report.warnings.push_back("removed " + temp_path.string() +
                                     ", left by a compaction that was cut short (the journal "
                                     "itself is complete)");
  } else if (errno != ENOENT) {
    opened.report.warnings.push_back("cannot remove " + temp_path.string() + ": " +
                                     std::strerror(errno));
  }
  entries_changed = entries_changed || !fs::exists(path, error);
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_APPEND | O_CLOEXEC, 0600);
  if (fd < 0) return SystemError("open " + path.string(), errno);
  journal->fd_ = fd;
  if (::flock(fd, LOCK_EX | LOCK_NB) != 0) {
    const int e = errno;
    if (e == EWOULDBLOCK) return Conflict(path.string());
    return SystemError("flock " + path.string(), e);
  }
  // Best effort: the records themselves are fdatasync'ed, and a lost new entry is recreated.
  if (entries_changed) (void)SyncDirectory(dir);

  auto bytes = ReadAll(fd, path.string());
  if (!bytes) return bytes.error();
  std::size_t complete_bytes = 0;
  opened.payloads = ParseJournal(bytes.value(), &opened.report, &complete_bytes);
  if (opened.report.torn_tail) {
    if (::ftruncate(fd, static_cast<off_t>(complete_bytes)) != 0 || ::fdatasync(fd) != 0) {
      return SystemError("cutting the torn last line off " + path.string(), errno);
    }
  }
  journal->bytes_ = static_cast<std::int64_t>(complete_bytes);
  journal->records_ = opened.report.good_records + opened.report.corrupt_lines;
  opened.journal = std::move(journal);
  return opened;
}

Journal::~Journal() {
  if (fd_ >= 0) ::close(fd_);
  ::close(lock_fd_);  // also releases the lock
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
  if (const int e = WriteAll(fd_, line); e != 0) {
    // Cut a partial record off so that the next one starts on a line of its own.
    (void)::ftruncate(fd_, before);
    return SystemError("write " + path_, e);
  }
  if (::fdatasync(fd_) != 0) {
    const int e = errno;
    (void)::ftruncate(fd_, before);
    return SystemError("fdatasync " + path_, e);
  }
  bytes_ = static_cast<std::int64_t>(before) + static_cast<std::int64_t>(line.size());
  ++records_;
  return Ok{};
}

Journal::Position Journal::End() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return Position{bytes_, records_, compactions_};
}

core::Result<CompactionReport> Journal::Compact(const Position& decided,
                                                const std::function<bool(std::string_view)>& keep) {
  std::lock_guard<std::mutex> compacting(compaction_mutex_);
  const Position snapshot = End();
  if (decided.compactions != snapshot.compactions || decided.bytes < 0 ||
      decided.bytes > snapshot.bytes) {
    return MakeError(ErrorCode::kInvalidArgument,
                     "Journal::Compact: the position is not one of the current journal file");
  }
  // While compaction_mutex_ is held, fd_ stays and the bytes below snapshot.bytes never change:
  // Append only adds after them. So they are read and filtered without blocking Append.
  auto prefix = ReadRange(fd_, 0, snapshot.bytes, path_);
  if (!prefix) return prefix.error();
  CompactionReport report;
  std::string kept;
  CopyKeptLines(prefix.value(), 0, decided.bytes, keep, &kept, &report.records_before,
                &report.records_after);
  prefix = std::string();

  const std::string temp_path = (std::filesystem::path(dir_) / kJournalTempFileName).string();
  TempFile temp(::open(temp_path.c_str(), O_RDWR | O_CREAT | O_TRUNC | O_APPEND | O_CLOEXEC, 0600),
                temp_path);
  if (temp.fd() < 0) return SystemError("open " + temp_path, errno);
  if (const int e = WriteAll(temp.fd(), kept); e != 0) return SystemError("write " + temp_path, e);
  if (::fsync(temp.fd()) != 0) return SystemError("fsync " + temp_path, errno);
  std::int64_t bytes_after = static_cast<std::int64_t>(kept.size());
  kept = std::string();

  std::lock_guard<std::mutex> lock(mutex_);
  // What was appended since the snapshot is copied as it is; Append waits from here on.
  auto tail = ReadRange(fd_, snapshot.bytes, bytes_, path_);
  if (!tail) return tail.error();
  std::string tail_kept;
  CopyKeptLines(tail.value(), snapshot.bytes, decided.bytes, keep, &tail_kept,
                &report.records_before, &report.records_after);
  if (!tail_kept.empty()) {
    if (const int e = WriteAll(temp.fd(), tail_kept); e != 0) {
      return SystemError("write " + temp_path, e);
    }
    if (::fsync(temp.fd()) != 0) return SystemError("fsync " + temp_path, errno);
    bytes_after += static_cast<std::int64_t>(tail_kept.size());
  }
  if (::flock(temp.fd(), LOCK_EX | LOCK_NB) != 0) return SystemError("flock " + temp_path, errno);
  if (::rename(temp_path.c_str(), path_.c_str()) != 0) {
    return SystemError("rename " + temp_path + " to " + path_, errno);
  }
  // From here on the new file is the journal, on disk and for Append.
  ::close(fd_);
  fd_ = temp.Release();
  report.bytes_before = bytes_;
  report.bytes_after = bytes_after;
  bytes_ = bytes_after;
  records_ = report.records_after;
  ++compactions_;
  // Until the folder is flushed the rename may not survive a power cut; Append waits for it, so
  // no record goes only to a file that could vanish.
  if (const int e = SyncDirectory(dir_); e != 0) {
    return SystemError("the journal was compacted, but fsync of the folder " + dir_ + " failed", e);
  }
  return report;
}

}  // namespace softgrasp::robot
