#include "base/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <ostream>
#include <streambuf>
#include <system_error>
#include <vector>

#include "base/error.h"

namespace raywarp {

namespace {

std::string os_error(int err) { return std::error_code(err, std::generic_category()).message(); }

// An output buffer onto a file descriptor that keeps the first error of write(2).
class FdBuffer : public std::streambuf {
 public:
  explicit FdBuffer(int fd) : fd_(fd), buffer_(size_t(1) << 16) {
    setp(buffer_.data(), buffer_.data() + buffer_.size());
  }
  // The first errno of a failed write, 0 when none.
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (!drain()) return traits_type::eof();
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    *pptr() = traits_type::to_char_type(c);
    pbump(1);
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n >= epptr() - pptr()) {  // large writes go straight to the file
      if (!drain() || !write_all(s, static_cast<size_t>(n))) return 0;
      return n;
    }
    return std::streambuf::xsputn(s, n);
  }
  int sync() override { return drain() ? 0 : -1; }

 private:
  bool drain() {
    const bool ok = write_all(pbase(), static_cast<size_t>(pptr() - pbase()));
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return ok;
  }
  bool write_all(const char* p, size_t n) {
    if (error_) return false;
    while (n > 0) {
      const ssize_t w = ::write(fd_, p, n);
      if (w < 0) {
        if (errno == EINTR) continue;
        error_ = errno;
        return false;
      }
      p += w;
      n -= static_cast<size_t>(w);
    }
    return true;
  }

  int fd_;
  std::vector<char> buffer_;
  int error_ = 0;
};

// Creates a temporary file beside `path` that no other writer (thread or process) uses:
// PATH.tmp-PID-N, created exclusively (a name left by a killed run is skipped). Returns its
// descriptor, or -1 with `err` set.
int create_temporary(const std::string& path, std::string& tmp, int& err) {
  static std::atomic<unsigned long> counter{0};
  for (int attempt = 0; attempt < 100; ++attempt) {
    tmp = path + ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
    // 0666 less the umask, as any file the user writes.
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    err = errno;
    if (err != EEXIST && err != EINTR) return -1;
  }
  return -1;
}

[[noreturn]] void fail(const std::string& path, int err) {
  throw Error(path + ": cannot write: " + os_error(err));
}

}  // namespace

void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write) {
  std::string tmp;
  int err = 0;
  const int fd = create_temporary(path, tmp, err);
  if (fd < 0) fail(path, err);
  auto discard = [&] { ::unlink(tmp.c_str()); };
  try {
    FdBuffer buffer(fd);
    std::ostream out(&buffer);
    write(out);
    out.flush();
    err = buffer.error();
    if (!err && !out) err = EIO;  // a stream error with no system error behind it
  } catch (...) {
    ::close(fd);
    discard();
    throw;
  }
  if (::close(fd) != 0 && !err) err = errno;
  if (!err && std::rename(tmp.c_str(), path.c_str()) != 0) err = errno;
  if (err) {
    discard();
    fail(path, err);
  }
}

void write_file_atomic(const std::string& path, const void* bytes, size_t size) {
  write_file_atomic(path, [&](std::ostream& out) {
    out.write(static_cast<const char*>(bytes), static_cast<std::streamsize>(size));
  });
}

void write_file_atomic(const std::string& path, std::string_view bytes) {
  write_file_atomic(path, bytes.data(), bytes.size());
}

}  // namespace raywarp
