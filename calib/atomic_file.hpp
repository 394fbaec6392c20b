#pragma once
// One way to replace a file that a reader, a crash or a power cut must see whole or not at
// all: run state, recordings, certificates, figures. (Four writers did this four ways; two
// did not fsync, one skipped the directory.)
#include <sys/types.h>

#include <string>
#include <string_view>

namespace standcal {

// Writes all of `text` to `fd`, again after EINTR and short writes; false, with errno
// set, on an error.
bool write_fully(int fd, std::string_view text);

// fsyncs a directory, so that a file created or renamed in it survives a power cut.
// Best effort: a directory that cannot be opened (no permission) is left as it is.
void fsync_directory(const std::string& dir);

// Writes `text` to PATH.tmp beside `path` (created with `mode`, less the umask), fsyncs
// it, renames it over `path` and fsyncs the directory. A device or a pipe (/dev/stdout, a
// FIFO) is written in place: a rename would replace the node. On failure the temporary is
// removed and std::runtime_error says "PATH: could not write WHAT (REASON)".
void write_file_atomically(const std::string& path, std::string_view text,
                           const std::string& what = "the file", mode_t mode = 0666);

}  // namespace standcal
