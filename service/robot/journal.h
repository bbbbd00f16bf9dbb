#pragma once
/// An append-only journal of text records on disk, one record per line, each line checksummed and
/// flushed to the disk (fdatasync) before Append returns. The command tracker writes its
/// accepted commands and their results here, so a restarted service loses none of them
/// (docs/robot-api.md, "Journal"). Compact rewrites the file without the records its caller no
/// longer needs and swaps it in atomically: a crash at any moment leaves the old file or the new
/// one, each complete.
///
/// Line format: `<crc32 of payload, 8 lower-case hex digits> <payload>\n`. A payload is any text
/// without '\n' (the tracker writes one JSON object per line).

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

#include "service/bridge/messages.h"
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
  /// True when a compaction's temporary file was found (a crash during a compaction) and removed.
  /// The journal itself is complete either way: the temporary file only replaces it once whole.
  bool removed_temp_file = false;
  /// One human-readable line per problem (line number and what was wrong), for the log.
  std::vector<std::string> warnings;
};

/// What one compaction did. Records are complete lines, good or damaged.
struct CompactionReport {
  std::int64_t records_before = 0;
  std::int64_t records_after = 0;
  std::int64_t bytes_before = 0;
  std::int64_t bytes_after = 0;
};

/// The file names inside the journal folder: the journal, the temporary file a compaction writes
/// before renaming it over the journal, and the file a running service holds locked.
inline constexpr char kJournalFileName[] = "robot-commands.jsonl";
inline constexpr char kJournalTempFileName[] = "robot-commands.jsonl.tmp";
inline constexpr char kJournalLockFileName[] = "robot-commands.lock";

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

  /// The end of the journal at one moment: how many bytes and complete lines (good or damaged) it
  /// held, and how many compactions had replaced the file before (offsets change with each).
  struct Position {
    std::int64_t bytes = 0;
    std::int64_t records = 0;
    std::int64_t compactions = 0;
  };

  /// Creates `dir` if needed (mode 0700), takes an exclusive lock on `dir`/robot-commands.lock
  /// (0600; a second service on the same folder gets kConflict), removes a compaction's leftover
  /// temporary file, opens or creates the journal file (0600), reads every record, and cuts a
  /// torn last line off. The journal file is locked too, so that a server which only knows that
  /// lock is refused as well. Errors: kInvalidArgument (empty dir), kConflict (locked), kInternal
  /// (I/O, with the system's message).
  static core::Result<Opened> Open(const std::string& dir);

  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  /// Writes one record and waits until it is on the disk. @pre payload has no '\n'
  /// (std::invalid_argument otherwise). kInternal on I/O errors (disk full, ...): the record may
  /// then be missing, never half-read later (its checksum would not match).
  core::Result<Ok> Append(std::string_view payload);

  /// Where the journal ends now. Every record that starts before `bytes` was appended before this
  /// call returned.
  Position End() const;

  /// Rewrites the journal without the records its caller no longer needs: `keep` is asked about
  /// each good record that starts before `decided.bytes` (a position End() gave since the last
  /// compaction); records appended after that position are all kept, damaged lines are not.
  /// The kept records go, in their order, to robot-commands.jsonl.tmp in the same folder, which
  /// is flushed (fsync), renamed over the journal, and the folder flushed. Appends carry on while
  /// the kept records are written and wait only for the last step (copying what was appended
  /// meanwhile, the fsyncs and the rename). `keep` runs while Append is free to proceed (only
  /// another Compact waits) and must not call Compact. On an error before the rename the old file
  /// stays in use, untouched; when only the last fsync of the folder fails, the new file is in use
  /// and the error says so. Errors: kInvalidArgument (`decided` is not a position of the current
  /// file), kInternal (I/O).
  core::Result<CompactionReport> Compact(const Position& decided,
                                         const std::function<bool(std::string_view)>& keep);

  const std::string& path() const { return path_; }

 private:
  Journal(int lock_fd, std::string dir, std::string path)
      : lock_fd_(lock_fd), dir_(std::move(dir)), path_(std::move(path)) {}

  const int lock_fd_;  // robot-commands.lock, held with flock for the journal's lifetime
  const std::string dir_;
  const std::string path_;
  std::mutex compaction_mutex_;  // one compaction at a time; held for a whole Compact
  mutable std::mutex mutex_;     // one writer at a time, so a failed write can be cut off cleanly
  // Guarded by mutex_; fd_ is only replaced by Compact, which also holds compaction_mutex_.
  int fd_ = -1;
  std::int64_t bytes_ = 0;    // the file's length: complete lines only
  std::int64_t records_ = 0;  // complete lines in the file
  std::int64_t compactions_ = 0;
};

}  // namespace softgrasp::robot
