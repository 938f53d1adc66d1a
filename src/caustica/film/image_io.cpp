#include "image_io.h"

#include <ImfArray.h>
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <stb/stb_image_write.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "../base/error.h"

namespace caustica {
namespace {

std::string extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext;
}

float srgb_encode(float v) {
  if (!(v > 0.f)) return 0.f;
  if (v >= 1.f) return 1.f;
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.f / 2.4f) - 0.055f;
}

void write_exr(const std::string& tmp, const std::vector<float>& rgb, int w, int h) {
  Imf::Header header(w, h);
  header.channels().insert("R", Imf::Channel(Imf::FLOAT));
  header.channels().insert("G", Imf::Channel(Imf::FLOAT));
  header.channels().insert("B", Imf::Channel(Imf::FLOAT));
  Imf::OutputFile file(tmp.c_str(), header);
  Imf::FrameBuffer fb;
  const size_t xs = 3 * sizeof(float), ys = xs * size_t(w);
  char* base = reinterpret_cast<char*>(const_cast<float*>(rgb.data()));
  fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0 * sizeof(float), xs, ys));
  fb.insert("G", Imf::Slice(Imf::FLOAT, base + 1 * sizeof(float), xs, ys));
  fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
  file.setFrameBuffer(fb);
  file.writePixels(h);
}

void write_pfm(const std::string& tmp, const std::vector<float>& rgb, int w, int h) {
  std::ofstream f(tmp, std::ios::binary);
  if (!f) throw std::runtime_error(std::strerror(errno));
  f << "PF\n" << w << " " << h << "\n-1\n";  // negative scale: little endian
  // PFM stores rows bottom to top.
  for (int y = h - 1; y >= 0; --y) f.write(reinterpret_cast<const char*>(&rgb[size_t(y) * w * 3]), sizeof(float) * 3 * w);
  f.flush();
  if (!f) throw std::runtime_error("write failed");
}

void write_png(const std::string& tmp, const std::vector<float>& rgb, int w, int h, float exposure) {
  float scale = std::exp2(exposure);
  std::vector<unsigned char> px(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i)
    px[i] = (unsigned char)std::lround(255.f * srgb_encode(rgb[i] * scale));
  if (!stbi_write_png(tmp.c_str(), w, h, 3, px.data(), w * 3)) throw std::runtime_error("PNG encoder failed");
}

}  // namespace

bool is_supported_image_extension(const std::string& path) {
  std::string e = extension(path);
  return e == ".exr" || e == ".pfm" || e == ".png";
}

void write_image(const std::string& path, const std::vector<float>& rgb, int w, int h, float exposure) {
  std::string ext = extension(path);
  if (!is_supported_image_extension(path))
    throw InputError("cannot write '" + path + "': unknown output format '" + ext + "' (allowed: .exr, .pfm, .png)");
  if (rgb.size() != size_t(w) * h * 3) throw InputError("write_image: the image is not " + std::to_string(w) + "x" + std::to_string(h) + "x3");
  namespace fs = std::filesystem;
  fs::path target(path);
  fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("cannot write '" + path + "': directory '" + dir.string() + "' does not exist");
  if (access(dir.c_str(), W_OK) != 0) throw InputError("cannot write '" + path + "': directory '" + dir.string() + "' is not writable");
  if (fs::is_directory(target, ec)) throw InputError("cannot write '" + path + "': it is a directory");
  std::string tmp = (dir / ("." + target.filename().string() + ".tmp-" + std::to_string(getpid()) + ext)).string();
  try {
    if (ext == ".exr") write_exr(tmp, rgb, w, h);
    else if (ext == ".pfm") write_pfm(tmp, rgb, w, h);
    else write_png(tmp, rgb, w, h, exposure);
  } catch (const std::exception& e) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + path + "': " + e.what());
  }
  fs::rename(tmp, target, ec);
  if (ec) {
    fs::remove(tmp, ec);
    throw InputError("cannot write '" + path + "': " + ec.message());
  }
}

std::vector<float> read_image(const std::string& path, int& w, int& h) {
  std::string ext = extension(path);
  if (ext == ".pfm") {
    std::ifstream f(path, std::ios::binary);
    std::string magic;
    float scale;
    f >> magic >> w >> h >> scale;
    f.get();
    if (!f || magic != "PF") throw InputError("cannot read '" + path + "': not an RGB PFM file");
    std::vector<float> img(size_t(w) * h * 3);
    for (int y = h - 1; y >= 0; --y) f.read(reinterpret_cast<char*>(&img[size_t(y) * w * 3]), sizeof(float) * 3 * w);
    if (!f) throw InputError("cannot read '" + path + "': truncated PFM file");
    return img;
  }
  if (ext == ".exr") {
    try {
      Imf::InputFile file(path.c_str());
      auto dw = file.header().dataWindow();
      w = dw.max.x - dw.min.x + 1;
      h = dw.max.y - dw.min.y + 1;
      std::vector<float> img(size_t(w) * h * 3);
      Imf::FrameBuffer fb;
      const size_t xs = 3 * sizeof(float), ys = xs * size_t(w);
      char* base = reinterpret_cast<char*>(img.data()) - (size_t(dw.min.x) * xs + size_t(dw.min.y) * ys);
      fb.insert("R", Imf::Slice(Imf::FLOAT, base + 0 * sizeof(float), xs, ys));
      fb.insert("G", Imf::Slice(Imf::FLOAT, base + 1 * sizeof(float), xs, ys));
      fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys));
      file.setFrameBuffer(fb);
      file.readPixels(dw.min.y, dw.max.y);
      return img;
    } catch (const std::exception& e) {
      throw InputError("cannot read '" + path + "': " + e.what());
    }
  }
  throw InputError("cannot read '" + path + "': unknown image format '" + ext + "' (allowed: .exr, .pfm)");
}

}  // namespace caustica
