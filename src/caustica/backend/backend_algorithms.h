// Small algorithms over the backend interface (backend.h) that more than one wavefront driver needs.
#pragma once
#include <cstdint>
#include <type_traits>
#include <utility>

#include "backend.h"

namespace caustica {

// The bits a radix sort needs for keys in [0, n): at least 1.
inline int key_bits_for(uint64_t n) {
  int bits = 1;
  while (bits < 64 && (uint64_t(1) << bits) < n) ++bits;
  return bits;
}

// Run starts of sorted keys: start[s] = the first position j < n with keys[j] >= s, for every s in
// [0, table] (start[table] = n; keys < table). Each s is written by exactly one thread (the position
// where the keys step past it), so no counting and no atomics: the same array as counting keys per value
// and taking an exclusive prefix sum.
template <class B>
void write_run_starts(const B& b, const uint32_t* keys, uint32_t n, uint32_t table, uint32_t* start) {
  b.parallel_for(n + 1, CAUSTICA_KERNEL(uint32_t j) {
    int64_t prev = j == 0 ? -1 : int64_t(keys[j - 1]);
    int64_t cur = j == n ? int64_t(table) : int64_t(keys[j]);
    for (int64_t s = prev + 1; s <= cur; ++s) start[s] = j;
  });
}

// Grows `buf` (a backend Buffer) to hold at least `need` elements, keeping its first `used` ones: doubles
// from `first` (or the current size) until it fits.
template <class B, class Buf>
void reserve_keep(const B& b, Buf& buf, size_t need, size_t used, size_t first) {
  if (buf.size() >= need) return;
  using T = std::remove_const_t<std::remove_reference_t<decltype(*buf.data())>>;
  size_t cap = buf.size() ? buf.size() : (first ? first : 1);
  while (cap < need) cap *= 2;
  Buf bigger(cap);
  const T* from = buf.data();
  T* to = bigger.data();
  b.parallel_for(uint32_t(used), CAUSTICA_KERNEL(uint32_t i) { to[i] = from[i]; });
  std::swap(buf, bigger);
}

// Stream compaction of a queue of path indices to the paths still active (flags, exclusive prefix sum,
// scatter: Harris, Sengupta & Owens 2007): queue2 receives them in queue order, then the two swap. Returns
// their number. `paths[i].active` says whether path i goes on.
template <class B, class T, class Buf>
uint32_t compact_queue(const B& b, const T* paths, Buf& queue, Buf& queue2, uint32_t* flags, uint32_t* scan,
                       uint32_t len) {
  const uint32_t* q = queue.data();
  b.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) { flags[k] = paths[q[k]].active ? 1u : 0u; });
  const uint32_t active = b.exclusive_scan(flags, scan, len);
  uint32_t* next = queue2.data();
  b.parallel_for(len, CAUSTICA_KERNEL(uint32_t k) {
    if (flags[k]) next[scan[k]] = q[k];
  });
  std::swap(queue, queue2);
  return active;
}

// Stable partition of the items [0, n) by flags[k] (0 or 1, filled by the caller): index[j] is the item at
// position j, those flagged 0 first, then those flagged 1, each part in item order (exclusive prefix sum and
// scatter, as compact_queue). scan: n entries. Returns the number flagged 1.
template <class B>
uint32_t stable_partition(const B& b, const uint32_t* flags, uint32_t* scan, uint32_t* index, uint32_t n) {
  const uint32_t ones = b.exclusive_scan(flags, scan, n), zeros = n - ones;
  b.parallel_for(n, CAUSTICA_KERNEL(uint32_t k) { index[flags[k] ? zeros + scan[k] : k - scan[k]] = k; });
  return ones;
}

}  // namespace caustica
