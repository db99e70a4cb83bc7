#include "io/safe_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <random>
#include <vector>

namespace pt {

namespace {

namespace fs = std::filesystem;

// testing::fail_writes_after: armed while fault_errno != 0, for one write_file_safely() call.
size_t fault_after_bytes = 0;
int fault_errno = 0;

[[noreturn]] void fail(const std::string& path, const std::string& what, int err) {
  throw FileError(path + ": " + what + " (" + std::strerror(err) + ")");
}

std::string parent_dir(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? "." : parent.string();
}

// The file a path finally names: symbolic links followed (the target may not exist yet).
std::string resolve_links(const std::string& path) {
  std::string p = path;
  for (int hops = 0; hops < 40; ++hops) {
    struct stat st {};
    if (lstat(p.c_str(), &st) != 0 || !S_ISLNK(st.st_mode)) return p;
    std::vector<char> buf(PATH_MAX + 1);
    const ssize_t n = readlink(p.c_str(), buf.data(), PATH_MAX);
    if (n < 0) return p;
    const std::string link(buf.data(), static_cast<size_t>(n));
    p = link.front() == '/' ? link : (fs::path(p).parent_path() / link).string();
  }
  fail(path, "cannot resolve", ELOOP);
}

// Writes all of `bytes`, retrying interrupted and partial writes. Returns 0 or the errno of the failure.
int write_all(int fd, std::string_view bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    size_t chunk = bytes.size() - done;
    if (fault_errno != 0) {
      if (done >= fault_after_bytes) return fault_errno;
      chunk = std::min(chunk, fault_after_bytes - done);
    }
    const ssize_t n = ::write(fd, bytes.data() + done, chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (n == 0) return EIO;
    done += static_cast<size_t>(n);
  }
  return 0;
}

// fsync where the file supports it (devices and pipes may not: EINVAL/EROFS/ENOTSUP are no failure there).
int sync_fd(int fd, bool regular) {
  if (fsync(fd) == 0) return 0;
  const int e = errno;
  if (!regular && (e == EINVAL || e == EROFS || e == ENOTSUP)) return 0;
  return e;
}

void write_in_place(const std::string& path, const std::string& target, const struct stat& st, std::string_view bytes) {
  const bool regular = S_ISREG(st.st_mode), fifo = S_ISFIFO(st.st_mode);
  // A FIFO opened without a reader would block for ever: open it non-blocking (ENXIO then), then block again.
  const int fd = ::open(target.c_str(), O_WRONLY | O_CLOEXEC | O_NOCTTY | (fifo ? O_NONBLOCK : 0));
  if (fd < 0) {
    if (fifo && errno == ENXIO) throw FileError(path + ": cannot write (no process is reading the FIFO)");
    fail(path, "cannot open for writing", errno);
  }
  auto close_and_fail = [&](const std::string& what, int err) {
    ::close(fd);
    fail(path, what, err);
  };
  if (fifo && fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK) != 0) close_and_fail("cannot write", errno);
  if (regular) {
    // In place means no way back once writing starts: make sure the new contents fit first.
    struct statvfs vfs {};
    if (fstatvfs(fd, &vfs) == 0 && bytes.size() > static_cast<size_t>(st.st_size)) {
      unsigned long long room = static_cast<unsigned long long>(vfs.f_bavail) * vfs.f_frsize;
      if (fault_errno == ENOSPC) room = fault_after_bytes;  // the simulated disk's room (testing::fail_writes_after)
      if (room < bytes.size() - static_cast<size_t>(st.st_size)) close_and_fail("cannot write", ENOSPC);
    }
  }
  if (const int e = write_all(fd, bytes)) close_and_fail("cannot write", e);
  if (regular && ftruncate(fd, static_cast<off_t>(bytes.size())) != 0) close_and_fail("cannot write", errno);
  if (const int e = sync_fd(fd, regular)) close_and_fail("cannot flush to disk", e);
  if (::close(fd) != 0) fail(path, "cannot write", errno);
}

std::string unique_suffix() {
  static std::mt19937_64 rng{std::random_device{}() ^ (static_cast<uint64_t>(getpid()) << 32)};
  char buf[24];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(rng()));
  return buf;
}

// Returns false (nothing changed) when the replacement could not be given the old file's owner: the caller then
// writes in place, which keeps it.
bool replace_atomically(const std::string& path, const std::string& target, const struct stat* old,
                        std::string_view bytes) {
  const std::string dir = parent_dir(target), name = fs::path(target).filename().string();
  std::string tmp;
  int fd = -1;
  for (int attempt = 0; attempt < 100 && fd < 0; ++attempt) {
    tmp = (fs::path(dir) / ("." + name + "." + unique_suffix() + ".tmp")).string();
    // O_EXCL: never reuse or clobber an existing file. New files get 0666 less the umask, like any program's.
    fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, old ? (old->st_mode & 07777) : 0666);
    if (fd < 0 && errno != EEXIST) fail(path, "cannot create a temporary file in " + dir, errno);
  }
  if (fd < 0) fail(path, "cannot create a temporary file in " + dir, EEXIST);
  auto abandon = [&](const std::string& what, int err) {
    ::close(fd);
    ::unlink(tmp.c_str());
    fail(path, what, err);
  };
  if (old) {
    if (fchmod(fd, old->st_mode & 07777) != 0) abandon("cannot keep the file's permissions", errno);
    struct stat now {};
    if (fstat(fd, &now) != 0) abandon("cannot write", errno);
    if ((now.st_uid != old->st_uid || now.st_gid != old->st_gid) && fchown(fd, old->st_uid, old->st_gid) != 0) {
      ::close(fd);
      ::unlink(tmp.c_str());
      return false;
    }
  }
  if (const int e = write_all(fd, bytes)) abandon("cannot write", e);
  if (fsync(fd) != 0) abandon("cannot flush to disk", errno);
  if (::close(fd) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    fail(path, "cannot write", e);
  }
  if (::rename(tmp.c_str(), target.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    fail(path, "cannot replace the file", e);
  }
  // The rename itself reaches the disk only with the directory.
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    const int r = fsync(dfd);
    const int e = errno;
    ::close(dfd);
    if (r != 0 && e != EINVAL && e != EROFS) fail(path, "cannot flush the directory to disk", e);
  }
  return true;
}

}  // namespace

void write_file_safely(const std::string& path, std::string_view bytes) {
  struct Disarm {  // a fault injected for this call never outlives it
    ~Disarm() { fault_errno = 0; }
  } disarm;
  if (path.empty()) throw FileError("cannot write a file with an empty name");
  const std::string target = resolve_links(path);
  struct stat st {};
  if (stat(target.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) fail(path, "cannot write", EISDIR);
    if (S_ISREG(st.st_mode)) {
      if (st.st_nlink > 1 || !replace_atomically(path, target, &st, bytes)) write_in_place(path, target, st, bytes);
      return;
    }
    if (S_ISFIFO(st.st_mode) || S_ISCHR(st.st_mode) || S_ISBLK(st.st_mode)) {
      write_in_place(path, target, st, bytes);
      return;
    }
    throw FileError(path + ": cannot write (not a regular file, device or FIFO)");
  }
  if (errno != ENOENT) fail(path, "cannot write", errno);
  replace_atomically(path, target, nullptr, bytes);
}

std::string check_output_path(const std::string& path) {
  if (path.empty()) return "empty file name";
  if (path.back() == '/') return path + ": names a directory, not a file";
  std::string target;
  try {
    target = resolve_links(path);
  } catch (const FileError& e) {
    return e.what();
  }
  auto reason = [&](const std::string& what, int err) { return path + ": " + what + " (" + std::strerror(err) + ")"; };
  struct stat st {};
  if (stat(target.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return reason("cannot write", EISDIR);
    if (!S_ISREG(st.st_mode) && !S_ISFIFO(st.st_mode) && !S_ISCHR(st.st_mode) && !S_ISBLK(st.st_mode))
      return path + ": cannot write (not a regular file, device or FIFO)";
    if (!S_ISREG(st.st_mode) || st.st_nlink > 1)
      return access(target.c_str(), W_OK) == 0 ? "" : reason("cannot write", errno);
  } else if (errno != ENOENT) {
    return reason("cannot write", errno);
  }
  const std::string dir = parent_dir(target);
  struct stat ds {};
  if (stat(dir.c_str(), &ds) != 0) return reason("directory " + dir + " is not usable", errno);
  if (!S_ISDIR(ds.st_mode)) return reason(dir + " is not a directory", ENOTDIR);
  if (access(dir.c_str(), W_OK | X_OK) != 0) return reason("directory " + dir + " is not writable", errno);
  return {};
}

FileId file_id(const std::string& path) {
  struct stat st {};
  if (stat(path.c_str(), &st) != 0) return {};
  return {static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino), true};
}

std::string read_file_limited(const std::string& path, size_t max_bytes) {
  auto too_large = [&](const std::string& size) {
    return FileError(path + ": file too large (" + size + " bytes; the limit is " + std::to_string(max_bytes) + ")");
  };
  int fd = STDIN_FILENO;
  if (path != "-") {
    struct stat st {};
    if (stat(path.c_str(), &st) != 0) fail(path, "cannot open", errno);
    if (S_ISDIR(st.st_mode)) fail(path, "cannot open", EISDIR);
    if (!S_ISREG(st.st_mode))
      throw FileError(path + ": not a regular file (a device, FIFO or socket; use - to read standard input)");
    if (static_cast<unsigned long long>(st.st_size) > max_bytes) throw too_large(std::to_string(st.st_size));
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) fail(path, "cannot open", errno);
    // What was opened may not be what was checked (the name can change in between): check the open file.
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
      ::close(fd);
      throw FileError(path + ": not a regular file");
    }
  }
  std::string data;
  std::vector<char> buf(1 << 16);
  for (;;) {
    const ssize_t n = ::read(fd, buf.data(), buf.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const int e = errno;
      if (fd != STDIN_FILENO) ::close(fd);
      fail(path, "cannot read", e);
    }
    if (n == 0) break;
    if (data.size() + static_cast<size_t>(n) > max_bytes) {
      if (fd != STDIN_FILENO) ::close(fd);
      throw too_large("more than " + std::to_string(max_bytes));
    }
    data.append(buf.data(), static_cast<size_t>(n));
  }
  if (fd != STDIN_FILENO) ::close(fd);
  return data;
}

namespace testing {
void fail_writes_after(size_t after_bytes, int error) {
  fault_after_bytes = after_bytes;
  fault_errno = error;
}
}  // namespace testing

}  // namespace pt
