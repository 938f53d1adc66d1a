// The film of the wavefront drivers that add one sample per pixel and pass (wavefront_path.h, wavefront_restir.h),
// in the backend's buffers: render.h's Film layout, 4 doubles per pixel (r, g, b, weight: sums of L * w and of
// the filter weights w) over all passes, and the same over the odd passes apart (the half image that --target-noise
// compares with the even passes).
#pragma once
#include <cstdint>
#include <vector>

#include "../backend/backend.h"
#include "../base/math.h"

namespace caustica {

// Adds pixel i's sample L with filter weight w to the sums (and to the odd passes' on an odd pass). Called from
// the drivers' kernels: slot i is pixel i, so no two threads add to the same pixel.
CHD void film_add(double* sum, double* odd, bool odd_pass, uint32_t i, RGB L, float weight) {
  const double w = double(weight);
  const double c[4] = {double(L.x) * w, double(L.y) * w, double(L.z) * w, w};
  for (int j = 0; j < 4; ++j) {
    sum[4 * size_t(i) + j] += c[j];
    if (odd_pass) odd[4 * size_t(i) + j] += c[j];
  }
}

template <class B>
class WavefrontFilm {
 public:
  WavefrontFilm(const B& backend, uint32_t pixels) : b_(backend), n_(pixels) {
    sum_.resize(size_t(n_) * 4);
    odd_.resize(size_t(n_) * 4);
    clear();
  }

  // (A member function: nvcc takes no extended __device__ lambda in a constructor.)
  void clear() {
    double* sum = sum_.data();
    double* odd = odd_.data();
    b_.parallel_for(4 * n_, CAUSTICA_KERNEL(uint32_t i) {
      sum[i] = 0.0;
      odd[i] = 0.0;
    });
  }

  double* sum() { return sum_.data(); }
  double* odd() { return odd_.data(); }

  // The sums, copied to the host.
  void to_host(std::vector<double>& sum, std::vector<double>& odd) const {
    sum.resize(size_t(n_) * 4);
    odd.resize(size_t(n_) * 4);
    b_.to_host(sum_, sum.data(), sum.size());
    b_.to_host(odd_, odd.data(), odd.size());
  }

 private:
  const B& b_;
  uint32_t n_;
  typename B::template Buffer<double> sum_, odd_;
};

}  // namespace caustica
