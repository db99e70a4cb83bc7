// Writing and reading files without losing data or trusting their size (docs/reliability.md).
//
// write_file_safely() is the one way the project writes an output file (images, scenes, reports):
// - A regular file (new, or existing with one link) is replaced atomically: the bytes go to a uniquely named
//   temporary file in the same directory, which is written in full, flushed (fsync), given the mode and owner
//   of the file it replaces, and renamed over it; then the directory is flushed. Any failure removes the
//   temporary file and leaves the earlier file as it was. A file that happens to be called `X.tmp` is never
//   touched (the temporary name is unique and created exclusively).
// - A symbolic link is followed: its target is written (the link stays a link).
// - A hard-linked regular file (more than one link) is written in place so every name keeps seeing it, after
//   checking that the file system has room for the new contents (a full disk fails before the first byte).
// - A device or FIFO (/dev/null, /dev/stdout, a pipe) is written in place; a FIFO without a reader fails at
//   once instead of blocking. Directories, sockets and the like are refused.
// Every step is checked and a failure names the path, the step and the system's reason (errno), e.g.
// "out.pfm: cannot write (No space left on device)".
#pragma once
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <string_view>

namespace pt {

struct FileError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

void write_file_safely(const std::string& path, std::string_view bytes);

// Checks, before any work is spent, that write_file_safely(path, ...) can succeed as far as can be known
// without writing: the directory exists and is writable (or the path is an existing writable device or FIFO,
// or a writable hard-linked file), and the path is not a directory. Returns "" or the reason.
std::string check_output_path(const std::string& path);

// Identity of an existing file (device and inode), to tell whether two paths name the same file.
struct FileId {
  uint64_t device = 0, inode = 0;
  bool exists = false;
  bool operator==(const FileId& o) const { return exists && o.exists && device == o.device && inode == o.inode; }
};
FileId file_id(const std::string& path);

// Reads a whole input file of at most `max_bytes`. Only regular files are read ("-" reads standard input, with
// the same cap): a FIFO, device or directory is refused before it is opened for reading, so /dev/zero or a
// FIFO cannot hang or exhaust memory. Throws FileError naming the path and the reason.
std::string read_file_limited(const std::string& path, size_t max_bytes);

namespace testing {
// Fault injection for tests: the next write_file_safely() fails its data writes with `error` (an errno value)
// once `after_bytes` bytes have been written, as a full disk would; with ENOSPC the disk also reports
// `after_bytes` bytes of room to the in-place writer's check. An error of 0 disarms it.
void fail_writes_after(size_t after_bytes, int error);
}  // namespace testing

}  // namespace pt
