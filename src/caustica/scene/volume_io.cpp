// Mitsuba's .vol density grids (volume_io.h).
#include "volume_io.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "../base/error.h"

namespace caustica {

namespace {

int32_t read_i32(const unsigned char* p) {
  return int32_t(uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24);
}
float read_f32(const unsigned char* p) {
  const uint32_t u = uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}
void put_i32(std::string& out, int32_t v) {
  const uint32_t u = uint32_t(v);
  for (int i = 0; i < 4; ++i) out.push_back(char((u >> (8 * i)) & 0xffu));
}
void put_f32(std::string& out, float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  for (int i = 0; i < 4; ++i) out.push_back(char((u >> (8 * i)) & 0xffu));
}

constexpr size_t kHeader = 48;  // "VOL", version, 5 int32, 6 float32

}  // namespace

MediumGridDesc read_vol_grid(const std::string& path, const std::string& referrer, Vec3f* bbox_lo, Vec3f* bbox_hi) {
  auto fail = [&](const std::string& what) -> void {
    throw InputError(referrer + ": density grid '" + path + "': " + what);
  };
  std::ifstream f(path, std::ios::binary);
  if (!f) fail("cannot open the file");
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  if (bytes.size() < kHeader || b[0] != 'V' || b[1] != 'O' || b[2] != 'L')
    fail("not a Mitsuba volume file (expected the bytes 'VOL' and a 48-byte header)");
  if (b[3] != 3) fail("volume file version " + std::to_string(int(b[3])) + " (expected 3)");
  const int32_t encoding = read_i32(b + 4);
  if (encoding != 1) fail("encoding " + std::to_string(encoding) + " (expected 1, float32)");
  const int32_t nx = read_i32(b + 8), ny = read_i32(b + 12), nz = read_i32(b + 16), channels = read_i32(b + 20);
  if (nx <= 0 || ny <= 0 || nz <= 0)
    fail("resolution " + std::to_string(nx) + " x " + std::to_string(ny) + " x " + std::to_string(nz) +
         " (expected at least 1 x 1 x 1)");
  if (channels != 1 && channels != 3)
    fail(std::to_string(channels) + " channels (expected 1, a density, or 3, a colour grid)");
  const uint64_t n = uint64_t(nx) * uint64_t(ny) * uint64_t(nz) * uint64_t(channels);
  if (n > (uint64_t(1) << 32) || bytes.size() != kHeader + n * 4)
    fail("expected " + std::to_string(kHeader + n * 4) + " bytes for " + std::to_string(nx) + " x " +
         std::to_string(ny) + " x " + std::to_string(nz) + " samples" +
         (channels > 1 ? " of " + std::to_string(channels) + " channels" : std::string()) + ", the file has " +
         std::to_string(bytes.size()));
  MediumGridDesc g;
  g.name = path;
  g.nx = nx;
  g.ny = ny;
  g.nz = nz;
  g.channels = channels;
  g.values.resize(size_t(n));
  for (size_t i = 0; i < size_t(n); ++i) {
    const float v = read_f32(b + kHeader + 4 * i);
    if (!(v >= 0.f) || !std::isfinite(v))
      fail("sample " + std::to_string(i) + " is " + std::to_string(v) + " (expected finite values >= 0)");
    g.values[i] = v;
  }
  if (bbox_lo) *bbox_lo = Vec3f(read_f32(b + 24), read_f32(b + 28), read_f32(b + 32));
  if (bbox_hi) *bbox_hi = Vec3f(read_f32(b + 36), read_f32(b + 40), read_f32(b + 44));
  return g;
}

void write_vol_grid(const MediumGridDesc& g, const std::string& path) {
  std::string out = "VOL";
  out.push_back(char(3));
  put_i32(out, 1);
  put_i32(out, g.nx);
  put_i32(out, g.ny);
  put_i32(out, g.nz);
  put_i32(out, g.channels);
  for (float v : {0.f, 0.f, 0.f, 1.f, 1.f, 1.f}) put_f32(out, v);
  for (float v : g.values) put_f32(out, v);
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary);
    if (!f) throw InputError("cannot write '" + path + "': cannot create the file");
    f.write(out.data(), std::streamsize(out.size()));
    if (!f) throw InputError("cannot write '" + path + "': write failed");
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw InputError("cannot write '" + path + "': " + ec.message());
  }
}

}  // namespace caustica
