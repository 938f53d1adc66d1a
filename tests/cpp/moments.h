// The mean and standard error of a running sum of independent estimates, for the tests that compare Monte
// Carlo means with closed forms (k standard errors).
#pragma once
#include <algorithm>
#include <cmath>

struct Moments {
  double sum = 0, sum2 = 0;
  long n = 0;
  void add(double x) {
    sum += x;
    sum2 += x * x;
    ++n;
  }
  double mean() const { return sum / double(n); }
  double se() const {
    double m = mean();
    return std::sqrt(std::max(0.0, sum2 / double(n) - m * m) / double(n - 1));
  }
};
