#pragma once
/// An append-only journal of text records on disk, one record per line, each line checksummed and
/// flushed to the disk (fdatasync) before Append returns. The command tracker writes its
/// accepted commands and their results here, so a restarted service loses none of them
/// (docs/robot-api.md, "Journal").
///
/// Line format: `<crc32 of payload, 8 lower-case hex digits> <payload>\n`. A payload is any text
/// without '\n' (the tracker writes one JSON object per line).

#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "service/bridge/dds.h"
#include "service/core/status.h"

namespace softgrasp::robot {

using bridge::Ok;

/// What reading a journal found besides its good records.
struct JournalReport {
  std::int64_t good_records = 0;
  /// Lines dropped because their checksum or format was wrong (corruption in the middle).
  std::int64_t corrupt_lines = 0;
  /// True when the file ended in a partial line (a crash in the middle of a write). That tail is
  /// cut off, so the next record starts on a line of its own.
  bool torn_tail = false;
  std::int64_t torn_tail_bytes = 0;
  /// One human-readable line per problem (line number and what was wrong), for the log.
  std::vector<std::string> warnings;
};

/// The file name inside the journal folder.
inline constexpr char kJournalFileName[] = "robot-commands.jsonl";

/// The checked form of one record, without the trailing newline. Exposed for tests.
std::string EncodeJournalLine(std::string_view payload);
/// The payload of one line (given without its newline); kUnprocessable saying what is wrong when
/// the line is malformed or its checksum does not match.
core::Result<std::string> DecodeJournalLine(std::string_view line);
/// CRC-32 (IEEE 802.3, the zlib one) of `bytes`.
std::uint32_t Crc32(std::string_view bytes);

/// Splits a whole journal file into payloads; never throws, whatever the bytes.
/// `complete_bytes` is set to the length of the prefix that ends with the last complete line.
std::vector<std::string> ParseJournal(std::string_view file_bytes, JournalReport* report,
                                      std::size_t* complete_bytes);

class Journal {
 public:
  struct Opened {
    std::unique_ptr<Journal> journal;
    std::vector<std::string> payloads;  ///< the good records, oldest first
    JournalReport report;
  };

  /// Creates `dir` if needed (mode 0700), opens or creates the journal file (0600), takes an
  /// exclusive lock on it (a second service on the same folder gets kConflict), reads every
  /// record, and cuts a torn last line off. Errors: kInvalidArgument (empty dir), kConflict
  /// (locked), kInternal (I/O, with the system's message).
  static core::Result<Opened> Open(const std::string& dir);

  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  /// Writes one record and waits until it is on the disk. @pre payload has no '\n'
  /// (std::invalid_argument otherwise). kInternal on I/O errors (disk full, ...): the record may
  /// then be missing, never half-read later (its checksum would not match).
  core::Result<Ok> Append(std::string_view payload);

  const std::string& path() const { return path_; }

 private:
  Journal(int fd, std::string path) : fd_(fd), path_(std::move(path)) {}
  std::mutex mutex_;  // one writer at a time, so a failed write can be cut off cleanly
  int fd_ = -1;
  std::string path_;
};

}  // namespace softgrasp::robot
