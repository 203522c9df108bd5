// Files written whole, atomically: the bytes go to a temporary file beside the path
// (PATH.tmp-PID-N, in the same folder, so on the same file system), which is flushed, closed and
// checked, then renamed over PATH. A reader sees the old file or the new one, never part of
// one, and a failure (a missing folder, a full disk, an exception while writing) removes the
// temporary and leaves PATH as it was. A run killed mid-write can leave a PATH.tmp-* file, never
// a half-written PATH.
#pragma once
#include <cstddef>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace raywarp {

// Writes `size` bytes to `path`. Throws Error naming the path and the system's error, e.g.
// "out/a.png: cannot write: No such file or directory".
void write_file_atomic(const std::string& path, const void* bytes, size_t size);
void write_file_atomic(const std::string& path, std::string_view bytes);
// Calls write(out), which writes the file's bytes into `out` (binary), then renames the file over
// `path`. An exception from `write` removes the temporary and propagates; a failure to write,
// flush, close or rename throws Error as above.
void write_file_atomic(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace raywarp
