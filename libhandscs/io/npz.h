// numpy's .npz archives (np.savez: a ZIP of .npy files, stored without compression), read into
// float64 arrays: the camera archives of NeuS, IDR and FMHR (`cameras.npz`, `param.npz`).
// Formats: ZIP's central directory (with its zip64 extension) and the .npy header
// (https://numpy.org/doc/stable/reference/generated/numpy.lib.format.html).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace handscs {

struct NpyArray {
  std::vector<int64_t> shape;
  std::vector<double> values;  // row-major (Fortran-order arrays are transposed on reading)
};

// Every array of the archive by name (without ".npy"). Reads little-endian float64, float32 and
// integer arrays. Throws Error naming the file and the entry for a compressed entry (np.savez_compressed:
// re-save with np.savez), another dtype, or a damaged archive.
std::map<std::string, NpyArray> read_npz(const std::string& path);

}  // namespace handscs
