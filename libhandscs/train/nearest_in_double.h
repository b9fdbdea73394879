// The last step of every L_con correspondence search. A float32 search (the GEMM, the k-d tree)
// cannot tell apart rows whose distances differ by less than its rounding, and two searches round
// differently: they settled such near-ties differently, so the same training step got different
// pairs and a different L_con on another CPU's BLAS kernel. So each search keeps every row within
// its rounding bound of its best, and this step picks among them by the distance in double, ties
// to the lowest row. The searches then agree row for row, on any machine.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <torch/types.h>

namespace handscs {

// How far a float32 search's squared distance can be from the true one, twice over (a comparison
// rounds two distances) and with a factor 2 to spare; u = 2^-24 is float32's unit roundoff.
constexpr double kFloatRoundoff = 1.0 / (1 << 24);

// The GEMM's |r|^2 - 2 q.r (d products per dot, both terms rounded at the scale of the norms, so
// the error grows with (|q| + |r|)^2 however near the rows are). query_norm, reference_norm: |q|
// and the largest |r|.
inline float gemm_search_tolerance(int64_t d, double query_norm, double reference_norm) {
  const double scale = query_norm + reference_norm;
  return static_cast<float>(4.0 * static_cast<double>(d + 2) * kFloatRoundoff * scale * scale);
}

// A direct sum of squared differences near the best squared distance `best`: d + 3 roundings of
// it; coordinates that were themselves rounded (the tree's rotated ones; rounded_norm = |q| in
// them, 0 for coordinates as given) add 2 |q - p| (|q| + |p|) u <= 2 sqrt(best) (2 |q| + sqrt(best)) u.
inline float direct_search_tolerance(int64_t d, double best, double rounded_norm) {
  const double b = std::max(best, 0.0);
  return static_cast<float>(4.0 * kFloatRoundoff *
                            (static_cast<double>(d + 5) * b + 4.0 * rounded_norm * std::sqrt(b)));
}

// Of `count` candidate rows of reference [*, d], the one nearest to query [d] in double; equal
// distances go to the lowest row. T: float or double (each difference is taken in double). A
// distance that is not a number never wins (the first row is returned when none is a number: the
// training checks skip such a step).
template <class T>
int64_t nearest_in_double(const T* query, const T* reference, int64_t d, const int64_t* rows,
                          int64_t count) {
  double best = std::numeric_limits<double>::infinity();
  int64_t arg = -1;
  for (int64_t c = 0; c < count; ++c) {
    const T* r = reference + rows[c] * d;
    double dist = 0;
    for (int64_t e = 0; e < d; ++e) {
      const double diff = static_cast<double>(query[e]) - static_cast<double>(r[e]);
      dist += diff * diff;
    }
    if (dist < best || (dist == best && rows[c] < arg)) best = dist, arg = rows[c];
  }
  return arg >= 0 ? arg : rows[0];
}

// The same for row `row` of query [N, d] against reference [N', d], both contiguous and of one
// dtype, float32 or float64.
inline int64_t nearest_in_double(const torch::Tensor& query, int64_t row, const torch::Tensor& reference,
                                 const std::vector<int64_t>& rows) {
  const int64_t d = query.size(1), count = static_cast<int64_t>(rows.size());
  return query.scalar_type() == torch::kFloat64
             ? nearest_in_double(query.data_ptr<double>() + row * d, reference.data_ptr<double>(), d,
                                 rows.data(), count)
             : nearest_in_double(query.data_ptr<float>() + row * d, reference.data_ptr<float>(), d,
                                 rows.data(), count);
}

}  // namespace handscs
