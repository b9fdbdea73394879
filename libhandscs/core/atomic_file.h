// Atomic file writes: write to "<path>.tmp.<pid>", fsync, rename over the target, fsync the folder.
// A crash at any point leaves either the old file or the new one, never a torn file.
#pragma once

#include <functional>
#include <string>

namespace handscs {

// Writes `bytes` to `path` atomically. Throws Error naming the path on failure.
void write_file_atomic(const std::string& path, const std::string& bytes);

// Reads a whole file; throws Error naming the path when it cannot be read.
std::string read_file(const std::string& path);

// Creates `dir` (and parents) if needed; throws Error naming it on failure.
void ensure_directory(const std::string& dir);

}  // namespace handscs
